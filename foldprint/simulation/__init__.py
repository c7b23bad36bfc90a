"""The fold of a design (nominal) and under scatter (jam probability)."""
