"""Hinge recovery R(t; material, bath, thickness) and the kinematics it drives."""
