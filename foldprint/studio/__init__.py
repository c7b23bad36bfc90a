"""``foldprint studio``: the designer's loop in the browser (docs/studio.md)."""
