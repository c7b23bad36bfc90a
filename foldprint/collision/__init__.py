"""Rigid panels, the paper's collision index (2D), the swept FCL check (3D), clearances and goals."""
