"""The paper's timing statements beside the model's (docs/structure-timings.md)."""

import re
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from foldprint.model.materials import default_library
from foldprint.simulation.paper_timings import (ModelValue, Statement, load_statements, measure,
                                     sample1_contact_ratio, verdict)
from foldprint.physics.recovery.curve import recovery_curve

DOC = Path(__file__).resolve().parent.parent / "docs" / "structure-timings.md"


@pytest.fixture(scope="module")
def model():
    return measure()


def test_every_statement_has_its_quote_and_source():
    st_ = load_statements()
    ids = [s.id for s in st_.items]
    assert len(ids) == len(set(ids))
    # every structure the paper times, and the ones it does not (self-lock), are listed
    for need in ("fig1b_spread_80", "fig1b_spread_100", "sample1_contact", "sample1_stop", "sample2_whole",
                 "sample2_inner_start", "sample2_inner_finish", "sample2_outer_start",
                 "sample2_outer_finish", "fig3b_order", "self_lock", "mailbox_whole"):
        assert need in ids
    for s in st_.items:
        assert s.quote.strip() and s.source.strip()
        assert (s.value_s is None) == (s.kind in ("none", "qualitative"))


def test_verdict_reads_the_kinds():
    tol = 0.5
    about = Statement("x", "x", "about", 7.0, "q", "s")
    assert verdict(about, ModelValue(7.4, ""), tol) == "meets"
    assert verdict(about, ModelValue(6.4, ""), tol) == "misses"
    assert verdict(about, ModelValue(None, ""), tol) == "never happens"
    at_most = Statement("x", "x", "at_most", 1.0, "q", "s")
    assert verdict(at_most, ModelValue(0.2, ""), tol) == "meets"
    assert verdict(at_most, ModelValue(1.6, ""), tol) == "misses"
    at_least = Statement("x", "x", "at_least", 3.0, "q", "s")
    assert verdict(at_least, ModelValue(9.0, ""), tol) == "meets"
    assert verdict(at_least, ModelValue(2.4, ""), tol) == "misses"


@settings(max_examples=12, deadline=None)
@given(tg1=st.floats(25.0, 75.0), dtg=st.floats(0.5, 20.0), bath=st.floats(70.0, 100.0),
       thickness=st.floats(0.4, 2.0))
def test_a_higher_tg_never_recovers_ahead(tg1, dtg, bath, thickness):
    """Why Sample 1's 7.5 s cannot be fitted beside Sample 2's 7 s (docs): at one bath and
    thickness, a hinge of higher Tg is behind a lower-Tg one at every instant, whatever the
    parameters (the shift factor rises with Tg on both sides of Tg)."""
    m = default_library()["H-3"]
    lo = recovery_curve(replace(m, tg_c=tg1), bath, thickness, horizon_s=60.0)
    hi = recovery_curve(replace(m, tg_c=tg1 + dtg), bath, thickness, horizon_s=60.0)
    assert np.all(hi.ratio <= lo.ratio + 1e-12)


def test_sample1_contact_ratio_is_set_by_the_geometry():
    """Nine identical hinges: the point ROM touches at one H-3 recovery ratio whatever the
    recovery parameters (the joint calibration's Sample 1 target relies on it), though at
    another time."""
    lib = default_library()
    r0 = sample1_contact_ratio(lib)
    from foldprint.model.materials import MaterialLibrary

    m = lib["H-3"]
    slower = replace(m, recovery=replace(m.recovery, h_w_m2k=m.recovery.h_w_m2k * 0.5))
    slow = MaterialLibrary(tuple(slower if x.name == "H-3" else x for x in lib.materials))
    r1 = sample1_contact_ratio(slow)
    assert 0.5 < r0 < 0.98
    assert r1 == pytest.approx(r0, abs=0.01)
    t0 = recovery_curve(lib["H-3"], 90.0).time_to(r0)
    t1 = recovery_curve(slow["H-3"], 90.0).time_to(r1)
    assert t1 > t0 + 0.3


def test_the_timeline_is_the_materials_curves(model):
    """Sample 2's measured times on the trajectory equal the free curves of its hinge
    materials (an independent path: no kinematics, no sampling), within a time step."""
    lib = default_library()
    c = {m: recovery_curve(lib[m], 90.0) for m in ("H-1", "H-2", "H-7")}
    dt = 0.01
    assert model["sample2_inner_start"].value_s == pytest.approx(c["H-2"].onset_time, abs=dt)
    assert model["sample2_inner_finish"].value_s == pytest.approx(c["H-2"].fold_time, abs=dt)
    assert model["sample2_outer_start"].value_s == pytest.approx(c["H-7"].onset_time, abs=dt)
    assert model["sample2_outer_finish"].value_s == pytest.approx(c["H-7"].fold_time, abs=dt)
    assert model["sample2_whole"].value_s == pytest.approx(c["H-7"].fold_time, abs=dt)


def _doc_rows():
    rows = {}
    for line in DOC.read_text(encoding="utf-8").splitlines():
        m = re.match(r"\|\s*`(\w+)`\s*\|(.*)", line)
        if m:
            rows[m.group(1)] = [c.strip() for c in m.group(2).split("|")]
    return rows


def test_the_docs_table_is_the_model(model):
    """docs/structure-timings.md: every statement has a row; its model column and verdict
    are what the model gives now."""
    st_ = load_statements()
    rows = _doc_rows()
    for s in st_.items:
        assert s.id in rows, f"docs/structure-timings.md has no row for {s.id}"
        cells = rows[s.id]
        v = model[s.id]
        model_cell, verdict_cell = cells[2], cells[3]
        if v.value_s is None:
            assert model_cell in ("—", "-", "none"), (s.id, model_cell)
        else:
            num = float(re.match(r"([0-9.]+)", model_cell).group(1))
            assert num == pytest.approx(v.value_s, abs=0.006), (s.id, model_cell, v.value_s)
        assert verdict_cell == verdict(s, v, st_.approx_tol_s), (s.id, verdict_cell)


def test_the_joint_fit_file_is_the_docs_joint_column():
    """foldprint/data/recovery_structure_fit.toml (the joint fit, not adopted) loads as a
    user materials file, gives every hinge material the same parameters, and its free-hinge
    Fig. 1b spreads are the docs' joint-fit column."""
    from foldprint.model.materials import load_library
    from foldprint.physics.recovery.table import fold_times

    path = Path(__file__).resolve().parent.parent / "foldprint" / "data" / "recovery_structure_fit.toml"
    lib = load_library(path)
    recs = {m.recovery for m in lib.hinges()}
    assert len(recs) == 1 and recs != {default_library()["H-1"].recovery}
    h1, h7 = fold_times(lib["H-1"], (80.0, 100.0)), fold_times(lib["H-7"], (80.0, 100.0))
    text = DOC.read_text(encoding="utf-8")
    for label, k in (("Fig. 1b spread, 80 °C", 0), ("Fig. 1b spread, 100 °C", 1)):
        line = next(ln for ln in text.splitlines() if ln.startswith(f"| {label}"))
        joint = float(line.rstrip(" |").split("|")[-1].strip(" *"))
        assert joint == pytest.approx(h7[k] - h1[k], abs=0.006), label
