"""Leaf utilities every layer may use: tolerances and defaults, errors, mode enums, the boundary schema, resource guards, the process pool."""
