"""Files in: TOML, FOLD and SVG designs become a Design; the shipped templates."""
