"""Cost models of the layers that know them, against what the work really takes: the 3D
narrow phase's open runs (a strip coiled onto itself, every pair a candidate), a
calibration fit, a bar-and-hinge run. Each estimate bounds a measured peak on a mid-size
case, and the large case is refused with its estimate before any of the work it
estimates is done."""

from __future__ import annotations

import time
import tracemalloc
from pathlib import Path

import pytest

from foldprint.core import guards
from foldprint.model.design import strip

GiB = 2 ** 30
ROOT = Path(__file__).resolve().parents[1]


pytestmark = pytest.mark.usefixtures("guard_defaults")


def _coil(n: int):
    """A helix-like strip whose 5 mm panels are shorter than its hinges (R 5 mm, 90 deg):
    it coils onto itself, so every pair of panels is a candidate of the broad phase."""
    return strip(f"coil{n}", [5.0] * n, [90.0] * (n - 1), [f"H-{1 + k % 7}" for k in range(n - 1)],
                 radius=5.0)


def _coil_toml(n: int) -> str:
    mats = [f"H-{1 + k % 7}" for k in range(n - 1)]
    return (f'schema = 1\nname = "coil{n}"\n[defaults]\nhinge_radius_mm = 5.0\n[strip]\n'
            f'lengths_mm = {[5] * n}\nangles_deg = {[90] * (n - 1)}\nmaterials = {mats}\n').replace("'", '"')


# -- the narrow phase ----------------------------------------------------------------------

def test_the_narrow_estimate_bounds_what_its_open_runs_hold(monkeypatch):
    """On a 60-panel coil (all 1,711 non-adjacent pairs candidates) the narrow phase's
    allocations (tracemalloc, from the broad phase's runs to the first contact: 8.8 MB
    measured) stay under the estimate, and the estimate is not a wild overestimate."""
    from foldprint.collision import swept_search
    from foldprint.collision.narrow_cost import narrow_estimate
    from foldprint.simulation.simulate import simulate

    seen = {}
    real_check, real_first = swept_search.check_narrow, swept_search.swept_first_contact

    def check(checker, runs, held=0.0):
        seen["est"] = narrow_estimate(checker, runs, held)
        return real_check(checker, runs, held)

    def first(*a, **k):
        tracemalloc.start()
        try:
            return real_first(*a, **k)
        finally:
            seen["peak"] = tracemalloc.get_traced_memory()[1]
            tracemalloc.stop()

    monkeypatch.setattr(swept_search, "check_narrow", check)
    monkeypatch.setattr("foldprint.simulation.simulate.swept_first_contact", first)
    d = _coil(60)
    res = simulate(d, method="fcl")
    assert res.contacts  # it does coil into itself
    est = seen["est"]
    assert est["runs"] == 60 * 59 / 2 - 59
    # what it allocates: the open runs, and the bound coordinates beside the trajectory held
    assert seen["peak"] <= est["bytes"] - guards.BASE_BYTES, (seen["peak"], est)
    assert seen["peak"] >= est["narrow_bytes"] / 5, (seen["peak"], est)


def test_the_narrow_phase_is_refused_before_any_pair_is_stepped(monkeypatch):
    from foldprint.collision import narrow_cost, swept3d, swept_search
    from foldprint.collision.narrow_cost import narrow_estimate
    from foldprint.simulation import costs
    from foldprint.simulation.simulate import simulate

    # open runs made costlier (100 KB each), so that the limit can sit between the
    # simulation's estimate and the narrow phase's
    monkeypatch.setattr(narrow_cost, "RUN_BYTES", 100_000)
    d = _coil(60)
    est = {}
    real = swept_search.check_narrow
    monkeypatch.setattr(swept_search, "check_narrow",
                        lambda c, runs, held=0.0: est.update(narrow_estimate(c, runs, held)) or real(c, runs, held))
    simulate(d, method="fcl")

    def boom(*a, **k):
        raise AssertionError("stepped despite the refusal")

    monkeypatch.setattr(swept3d.SweptChecker, "steps", boom)
    guards.set_max_memory(int(est["bytes"]) - 1)
    assert costs.check_simulation(d, 0.01, None, "fcl")["bytes"] < est["bytes"] - 1
    with pytest.raises(guards.ResourceError, match=r"coil60: the 3D swept check refused: its narrow phase holds "
                                                   r"1711 candidate panel-pair runs open at once"):
        simulate(d, method="fcl")


def test_a_1000_panel_coil_is_answered_within_a_minute_under_the_default_limit(tmp_path):
    """Before: past 300 s and 9.2 GB resident under the 2 GiB guard; now refused (exit 2,
    one line naming the estimate) once the broad phase has left its 498,501 runs."""
    from fuzz_gen import run_fresh

    (tmp_path / "coil.toml").write_text(_coil_toml(1000))
    res = run_fresh(["check", "coil.toml", "--samples", "0"], tmp_path, address_limit=2 * GiB + 2 ** 29, cpu_s=60)
    assert res["code"] == 2, res["err"][-1000:]
    assert "narrow phase holds 498501 candidate panel-pair runs" in res["err"] and res["err"].count("\n") == 1
    assert res["cpu_seconds"] < 60 and res["peak_mib"] < 2 * 1024


# -- a calibration fit ---------------------------------------------------------------------

HEAD = "kind,material,reference,bath_c,thickness_mm,initial_c,time_s,level,value,relation,sigma,source\n"


def _curves_csv(n: int) -> str:
    """``n`` ratio rows of H-1 at ``n`` bath temperatures: one curve each."""
    return HEAD + "".join(f"ratio,H-1,,{60 + 39.9 * k / n:.5f},0.8,10,3,,0.5,,,\n" for k in range(n))


def test_the_fit_estimate_bounds_a_measured_fit():
    """20 curves, the shipped number of starts, no profile: CPU and the allocations of the
    fit under the estimate, and within 15x of it."""
    from foldprint.apps import calibrate as cal
    from foldprint.io.hinge_data import parse_hinge_data
    from foldprint.model.materials import default_library
    from foldprint.physics.calibration.fit_cost import fit_estimate

    data = parse_hinge_data(_curves_csv(20), "c.csv")
    seen = {}
    real = cal.check_fit

    def check(problem, starts, with_profile=True):
        seen["est"] = fit_estimate(problem, starts, with_profile)
        return real(problem, starts, with_profile)

    cal.check_fit = check
    try:
        tracemalloc.start()
        t0 = time.process_time()
        c = cal.calibrate(data, default_library(), with_profile=False)
        cpu = time.process_time() - t0
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
        cal.check_fit = real
    est = seen["est"]
    assert est["curves"] == 20 and c.fit.nfev > 0
    assert cpu <= est["seconds"] <= 15 * cpu, (cpu, est)
    assert peak <= est["bytes"] - guards.BASE_BYTES, (peak, est)


def test_rows_read_off_a_curve_at_once_are_the_rows_read_one_by_one():
    """predict reads a curve's ratio and angle rows in one interpolation: bit for bit what
    predict_row gives row by row, with time_to and spread rows and one-sided relations."""
    import numpy as np

    from foldprint.io.hinge_data import parse_hinge_data
    from foldprint.model.materials import default_library
    from foldprint.physics.calibration.fit import Problem

    head = HEAD.rstrip("\n") + ",printed_deg\n"
    rows = ([f"ratio,H-1,,{60 + k},0.8,10,{0.5 + k / 7},,0.5,,,," for k in range(30)]
            + [f"angle,H-3,,90,0.8,10,{1 + k / 3},,{100 + k},,,,{80 + k}" for k in range(20)]
            + ["time_to,H-7,,90,0.8,10,,0.98,7,at_most,,,", "spread,H-7,H-1,80,0.8,10,,0.98,7.0,at_least,0.5,,"])
    pb = Problem(parse_hinge_data(head + "\n".join(rows) + "\n", "m.csv"), default_library())
    rng = np.random.default_rng(7)
    for _ in range(3):
        x = pb.lower + (pb.upper - pb.lower) * rng.uniform(0.1, 0.9, len(pb.params))
        curves = pb.curves(x)
        one_by_one = np.array([pb.predict_row(o, curves) for o in pb.data.observations])
        assert np.array_equal(pb.predict(x), one_by_one)
        d = one_by_one - np.array([o.value for o in pb.data.observations])
        d[-2], d[-1] = max(d[-2], 0.0), min(d[-1], 0.0)  # at_most, at_least
        assert np.array_equal(pb.residuals_of(one_by_one), d / pb.sigmas)


@pytest.mark.parametrize("n, limit", [(50_000, "memory limit"), (5_000, "time budget")])
def test_a_fit_too_large_is_refused_before_the_first_curve(monkeypatch, n, limit):
    """50,000 curves ended in MemoryError, 5,000 ran for many minutes: both refused from
    the problem's size, before any curve is made."""
    from foldprint.apps import calibrate as cal
    from foldprint.io.hinge_data import parse_hinge_data
    from foldprint.model.materials import default_library
    from foldprint.physics.calibration.fit import Problem

    def boom(*a, **k):
        raise AssertionError("a curve was made despite the refusal")

    monkeypatch.setattr(Problem, "curves", boom)
    data = parse_hinge_data(_curves_csv(n), "big.csv")
    t0 = time.process_time()
    with pytest.raises(guards.ResourceError, match=rf"big.csv: calibrate refused: {n} rows on {n} curves .*{limit}"):
        cal.calibrate(data, default_library())
    assert time.process_time() - t0 < 10


# -- a bar-and-hinge run -------------------------------------------------------------------

def test_the_bar_hinge_estimate_bounds_a_measured_run():
    """The Miura template under --mechanics bar-hinge: the model's size counted from the
    design bounds the built model's, and the solve's CPU and allocations stay under the
    estimate (within 25x)."""
    from foldprint.io.load import load_design
    from foldprint.physics.barhinge.model import build
    from foldprint.physics.barhinge.solve_cost import mechanics_estimate
    from foldprint.physics.barhinge.equilibrium import CompliantDrive

    d = load_design(ROOT / "templates" / "miura_3x3.toml")
    est = mechanics_estimate(d)
    model = build(d)
    assert len(model.nodes) <= est["nodes"] and len(model.bars) <= est["bars"]
    assert len(model.springs) <= est["springs"]
    t0 = time.process_time()
    CompliantDrive(d).solve()  # 247 Newton iterations, 0.7 CPU-s measured
    cpu = time.process_time() - t0
    drive = CompliantDrive(d)
    tracemalloc.start()  # (tracing makes the solve several times slower: timed above without it)
    try:
        drive.solve()
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert cpu <= est["seconds"] <= 25 * max(cpu, 0.1), (cpu, est)
    assert peak <= est["bytes"] - guards.BASE_BYTES, (peak, est)


def test_a_bar_hinge_run_over_the_budget_is_refused_before_the_model_is_built(monkeypatch):
    import foldprint.physics.barhinge.equilibrium as solve
    from foldprint.io.load import load_design
    from foldprint.physics.barhinge.solve_cost import mechanics_estimate
    from foldprint.simulation.simulate import simulate

    def boom(*a, **k):
        raise AssertionError("built despite the refusal")

    monkeypatch.setattr(solve, "build", boom)
    d = load_design(ROOT / "templates" / "miura_3x3.toml")
    guards.set_time_budget(mechanics_estimate(d)["seconds"] / 2)
    with pytest.raises(guards.ResourceError, match=r"--mechanics bar-hinge refused: its model of \d+ nodes.*time budget"):
        simulate(d, mechanics="bar-hinge")


# -- a loop closure ------------------------------------------------------------------------

def test_the_loop_estimate_bounds_a_measured_closure():
    """A 6 x 6 Miura sheet's closure tracked over a 2 s fold: the solver's allocations
    (tracemalloc, its tables and every round's Jacobians) stay under the estimate."""
    import numpy as np

    from foldprint.io.fold_format import design_from_fold
    from foldprint.model.crease_patterns import miura
    from foldprint.physics.hinge_drive import HingeDrive
    from foldprint.physics.loops.closure_cost import loop_estimate

    d = design_from_fold(miura(6, 6), "miura6")
    times = np.linspace(0.0, 2.0, 201)
    # the compiled kernels loaded first (on an empty numba cache, compiled): their compilation
    # is not the solver's memory, and their types do not depend on the pattern
    warm = HingeDrive(design_from_fold(miura(2, 2), "warm"))
    warm.loops.track(times[:3], warm.driven(times[:3]))
    tracemalloc.start()
    try:
        drive = HingeDrive(d)
        loops = drive.loops
        loops.track(times, drive.driven(times))
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    est = loop_estimate(loops.n, len(loops.cycles), max(len(c) for c in loops.cycles))
    assert len(loops.cycles) == 25
    assert peak <= est["bytes"] - guards.BASE_BYTES + 20 * 2 ** 20, (peak, est)  # + the drive's curves


def test_a_1500_face_sheet_is_refused_before_its_loop_tables_are_made():
    """A 30 x 50 Miura sheet (1,421 loops over 2,920 hinges) ended in MemoryError: its
    closure is refused from the loops' sizes, in seconds."""
    from foldprint.io.fold_format import design_from_fold
    from foldprint.model.crease_patterns import miura
    from foldprint.physics.hinge_drive import HingeDrive

    d = design_from_fold(miura(30, 50), "miura1500")
    t0 = time.process_time()
    with pytest.raises(guards.ResourceError, match=r"loop closure refused: 1421 loops .* over 2920 hinges"):
        HingeDrive(d)
    assert time.process_time() - t0 < 20


def test_a_bar_hinge_sample_estimate_bounds_a_measured_sample():
    """A Monte-Carlo sample under --mechanics bar-hinge solves its own equilibrium path:
    the estimate from the nominal fold's Newton iterations bounds the CPU of scattered
    samples of the Miura template (measured 1.1 CPU-s a sample against 1.4 estimated),
    within 5x."""
    from foldprint.core.constants import CHECK_DT_S
    from foldprint.core.modes import Mechanics, Method
    from foldprint.io.load import load_design
    from foldprint.model.materials import default_library
    from foldprint.physics.barhinge.solve_cost import solve_seconds
    from foldprint.simulation.costs import simulation_estimate
    from foldprint.simulation.robust import run_samples
    from foldprint.simulation.scatter import default_scatter, iter_samples
    from foldprint.simulation.simulate import simulate

    d = load_design(ROOT / "templates" / "miura_3x3.toml")
    nom = simulate(d, dt=CHECK_DT_S, mechanics="bar-hinge")
    sol = nom.compliant
    per = solve_seconds(sol.model, sol.iterations) + simulation_estimate(
        len(d.panels), len(d.hinges), len(nom.trajectory.times), False)["seconds"]
    samples = list(iter_samples(d, default_scatter(), 3, 5))
    t0 = time.process_time()
    out = run_samples((d, default_library(), samples, nom.trajectory.model, CHECK_DT_S, False, Method.FCL,
                       Mechanics.BAR_HINGE))
    cpu = (time.process_time() - t0) / len(samples)
    assert len(out) == 3
    assert cpu <= per <= 5 * cpu, (cpu, per)


@pytest.mark.parametrize("stage", ["robust", "check"])
def test_bar_hinge_samples_over_the_budget_are_refused_before_the_first_is_folded(monkeypatch, stage):
    """octagon_stack's check under --mechanics bar-hinge was refused only once its first
    chunk of 16 compliant folds had been timed (92 s): now from the nominal fold's path,
    before any sample is folded, naming the estimate and how to raise the budget."""
    from foldprint.core.constants import CHECK_DT_S
    from foldprint.io.load import load_design
    from foldprint.simulation import robust
    from foldprint.simulation.costs import check_mechanics_samples
    from foldprint.simulation.jamtest.scales import jam_test, jam_tests
    from foldprint.simulation.simulate import simulate

    d = load_design(ROOT / "templates" / "miura_3x3.toml")
    nom = simulate(d, dt=CHECK_DT_S, mechanics="bar-hinge")
    guards.set_time_budget(1e9)
    est = check_mechanics_samples(nom, 64, 1, d.name)  # under a budget that holds it: not refused

    def boom(*a, **k):
        raise AssertionError("a sample was folded despite the refusal")

    monkeypatch.setattr(robust, "run_samples", boom)
    monkeypatch.setattr("foldprint.simulation.jamtest.scales.run_samples", boom)
    monkeypatch.setattr("foldprint.simulation.jamtest.scales.run_batch", boom)
    guards.set_time_budget(est / 2)
    pattern = (r"miura_3x3: --samples \d+ refused: estimated [0-9.e+]+ s \([0-9.e+]+ ms per sample estimated from "
               r"the nominal fold's \d+ Newton iterations on \d+ nodes, on 1 worker\(s\)\).*FOLDPRINT_TIME_BUDGET")
    with pytest.raises(guards.ResourceError, match=pattern):
        if stage == "robust":
            robust.jam_probability(d, 64, nominal=nom, dt=CHECK_DT_S, workers=1, mechanics="bar-hinge")
        else:
            jam_tests(d, jam_test(0.05, 0.2, 64), (1.0,), nominal=nom, dt=CHECK_DT_S, workers=1,
                      mechanics="bar-hinge")


def _materials_csv(n: int) -> str:
    """``n`` new materials, each with its Tg and three ratio rows at 80 C."""
    rows = []
    for k in range(n):
        m = f"M{k + 1}"
        rows += [f"tg,{m},,,,,,,{35 + 30 * k / max(n - 1, 1):.2f},,,DMA", f"ratio,{m},,80,,,2,,0.2,,,",
                 f"ratio,{m},,80,,,5,,0.7,,0.03,", f"ratio,{m},,80,0.8,10,10,,0.97,,,"]
    return HEAD + "\n".join(rows) + "\n"


def test_300_new_materials_are_refused_at_once_under_the_default_budget(monkeypatch):
    """300 new materials (7.9 min estimated; 30 of them took 35 CPU-s against 48 s
    estimated) ran under a 15 min budget: the default budget refuses them before the
    first curve, naming the estimate and how to lift the budget; 10 materials fit."""
    from foldprint.apps import calibrate as cal
    from foldprint.io.hinge_data import parse_hinge_data
    from foldprint.model.materials import default_library
    from foldprint.physics.calibration.fit import Problem

    real = Problem.curves

    def boom(*a, **k):
        raise AssertionError("a curve was made despite the refusal")

    monkeypatch.setattr(Problem, "curves", boom)
    t0 = time.process_time()
    with pytest.raises(guards.ResourceError, match=r"m.csv: calibrate refused: 900 rows on 300 curves .*take about "
                                                   r"[0-9.]+ min, over the 1 min time budget.*FOLDPRINT_TIME_BUDGET"):
        cal.calibrate(parse_hinge_data(_materials_csv(300), "m.csv"), default_library())
    assert time.process_time() - t0 < 10
    monkeypatch.setattr(Problem, "curves", real)
    assert _fit_estimate(parse_hinge_data(_materials_csv(10), "m.csv"))["seconds"] < guards.time_budget()


def _fit_estimate(data) -> dict:
    """The estimate calibrate's guard makes of ``data``'s fit (its held parameters, its starts)."""
    from foldprint.apps.calibrate import FITTABLE, holds
    from foldprint.model.materials import default_library
    from foldprint.physics.calibration.fit import Problem
    from foldprint.physics.calibration.fit_cost import fit_estimate

    held_by = holds(None, ())
    names = {h.name for h in held_by}
    pb = Problem(data, default_library(), free=tuple(n for n in FITTABLE if n not in names),
                 fixed={h.name: h.value for h in held_by if h.value is not None})
    return fit_estimate(pb, pb.config.starts)


def test_the_default_budget_holds_every_shipped_template_and_data_set():
    """What the default budget must not refuse (docs/input-safety.md): each template's
    bar-and-hinge run and the shipped calibration data's fit, estimated, with a margin of
    2x under the budget."""
    from foldprint.io.hinge_data import parse_hinge_data
    from foldprint.io.load import load_design
    from foldprint.physics.barhinge.solve_cost import mechanics_estimate

    budget = guards.time_budget()
    assert budget == guards.DEFAULT_TIME_BUDGET_S == 60.0
    for path in sorted((ROOT / "templates").glob("*.toml")):
        assert mechanics_estimate(load_design(path))["seconds"] < budget / 2, path.name
    data = parse_hinge_data((ROOT / "foldprint" / "data" / "paper_hinge_data.csv").read_text(), "paper.csv")
    assert _fit_estimate(data)["seconds"] < budget / 2
