"""Figures, stills, scenes, animations and the interactive viewer."""
