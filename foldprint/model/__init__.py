"""The design and what it is made of: materials, panels and hinges, crease patterns, vertex reliefs."""
