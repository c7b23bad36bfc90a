"""Hypothesis strategies for patterns with closed loops, shared by the tests that compare
the loop tracker's compiled and numpy paths."""

from __future__ import annotations

from hypothesis import strategies as st

from foldprint.io.fold_format import design_from_fold
from foldprint.model import crease_patterns as cp


@st.composite
def loop_patterns(draw):
    """A random Miura-ori patch (2-3 x 2-3 panels, random panel shape), a flat-foldable
    degree-4 vertex (random sector angles) or a waterbomb base (random drive)."""
    kind = draw(st.sampled_from(["miura", "degree4", "waterbomb"]))
    if kind == "miura":
        nx, ny = draw(st.integers(2, 3)), draw(st.integers(2, 3))
        fold = cp.miura(nx, ny, width=draw(st.floats(12.0, 30.0)), height=draw(st.floats(10.0, 25.0)),
                        shift=draw(st.floats(2.0, 9.0)), zigzag_deg=draw(st.floats(60.0, 150.0)))
    elif kind == "degree4":
        a = draw(st.floats(30.0, 80.0))
        fold = cp.degree4(a, draw(st.floats(a + 10.0, 150.0)), rho1_deg=draw(st.floats(-150.0, -30.0)))
    else:
        fold = cp.waterbomb(diagonal_deg=draw(st.floats(30.0, 120.0)))
    return design_from_fold(fold)
