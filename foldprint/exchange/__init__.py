"""Every byte foldprint writes goes through this package (trimesh's ``exchange`` idea)."""
