"""Inverse design (foldprint assign): the answers are checked against independent runs of
the simulation of record, the search against its own invariants, and a Dask cluster
against local processes."""

import json
from pathlib import Path
import re

import pytest

from foldprint.apps.assign.search import assign, permanent_crossings, temperature_grid, with_materials
from foldprint.apps.assign.waves import connected_waves
from foldprint.cli.commands import main
from foldprint.model.design import strip
from foldprint.io.design_io import design_to_toml
from foldprint.io.load import load_design
from foldprint.core.errors import DesignError
from foldprint.core.modes import Method, Objective
from foldprint.physics.recovery.curve import recovery_curve
from foldprint.simulation.simulate import simulate
from foldprint.io.templates import resolve_design_path

#: panels p1 and p3 cross in the printed state
CROSSING = Path(__file__).parent / "data" / "crossing.toml"


def _small_spiral(materials=("H-3", "H-3", "H-3")):
    """The first four panels of the paper's helix (three corner hinges)."""
    return strip("spiral4", [30, 30, 35.8, 35.8], [90, 90, 90], list(materials), radius=5.0)


@pytest.fixture(scope="module")
def helix():
    return load_design(resolve_design_path("helix_uniform"))


@pytest.fixture(scope="module")
def helix_margin(helix):
    # three materials keep the test quick (3^9 assignments); docs/assign.md records the
    # full seven-material run
    return assign(helix, materials=["H-1", "H-4", "H-7"], objective="margin", top=3, budget=48)


def test_connected_waves_of_a_strip_are_its_intervals():
    graph = [{1}, {0, 2}, {1, 3}, {2}]  # four hinges in a row
    rest = frozenset(range(4))
    waves = connected_waves(rest, graph)
    assert waves[0] == rest  # "all the rest" first: every prefix can be completed
    intervals = {frozenset(range(a, b)) for a in range(4) for b in range(a + 1, 5)}
    assert set(waves) == intervals
    # a disconnected remainder: its groups and the whole remainder, nothing bridging the gap
    waves = connected_waves(frozenset({0, 2, 3}), graph)
    assert set(waves) == {frozenset({0, 2, 3}), frozenset({0}), frozenset({2}), frozenset({3}), frozenset({2, 3})}


def test_temperature_grid_spans_the_range_in_5_c_steps():
    g = temperature_grid(80, 100)
    assert g[0] == 80 and g[-1] == 100 and len(g) == 5
    assert max(b - a for a, b in zip(g, g[1:])) <= 5.0 + 1e-9
    assert temperature_grid(90, 90) == (90.0,)


def test_helix_assignments_fold_and_fold_inner_first(helix, helix_margin, lib):
    r = helix_margin
    assert r.best, r.to_json()["blocking"]
    assert r.evaluated <= 48 and r.search_space == 3 ** 9
    for c in r.best:
        d = with_materials(helix, c.materials, c.bath_c)
        # an independent run: the simulation of record, 3D swept check and 2D index together
        res = simulate(d, method=Method.BOTH)
        assert res.completed, c.materials
        assert res.fold_time == pytest.approx(c.fold_time, abs=0.02)
    # the paper's insight: no hinge folds later than the hinges outside it (h1 innermost)
    best = r.best[0]
    ft = [recovery_curve(lib[m], best.bath_c, 0.8, 10.0).time_to(0.98) for m in best.materials]
    assert all(a <= b + 1e-9 for a, b in zip(ft, ft[1:])), best.materials
    # ranked by the objective
    cl = [c.clearance_mm for c in r.best]
    assert cl == sorted(cl, reverse=True)


def test_helix_failures_are_tallied_most_frequent_first(helix_margin):
    """Some fold orders of the helix collide; the search counts their first pairs."""
    blocking = helix_margin.to_json()["blocking"]
    assert blocking and all(b["count"] >= 1 for b in blocking)
    assert sum(b["count"] for b in blocking) <= helix_margin.evaluated
    assert [b["count"] for b in blocking] == sorted((b["count"] for b in blocking), reverse=True)


def test_the_objective_is_an_enum_below_the_boundary_and_a_string_outside(helix_margin, tmp_path, capsys):
    """Modes are enums below the boundary: ``assign`` parses its objective to an :class:`Objective` (member or text,
    like the other modes); its JSON keeps the plain string and the CLI its message."""
    assert helix_margin.objective is Objective.MARGIN
    out = json.loads(json.dumps(helix_margin.to_json()))
    assert type(helix_margin.to_json()["objective"]) is str and out["objective"] == "margin"
    with pytest.raises(DesignError, match="'fastest' is not one of time, margin, robust"):
        assign(_small_spiral(), objective="fastest")
    f = tmp_path / "spiral.toml"
    f.write_text(design_to_toml(_small_spiral()))
    assert main(["assign", str(f), "--objective", "fastest"]) == 2
    assert capsys.readouterr().err.endswith("--objective must be one of time, margin, robust, got 'fastest'\n")
    for objective in Objective:  # every member's text is an option value (checked, not run: --top 0)
        assert main(["assign", str(f), "--objective", objective.value, "--top", "0"]) == 2
        assert "--top" in capsys.readouterr().err


def test_crossing_design_exits_1_naming_the_pair(capsys):
    f = CROSSING
    assert permanent_crossings(load_design(f)) == [("p1", "p3")]
    code = main(["assign", str(f), "--json"])
    cap = capsys.readouterr()
    assert code == 1
    out = json.loads(cap.out)
    assert out["best"] == [] and out["blocking"][0]["pair"] == ["p1", "p3"]
    assert "p1 and p3" in cap.err and "permanent" in cap.err


def test_fixed_hinge_keeps_its_material_and_write_round_trips(tmp_path, capsys):
    d = _small_spiral()
    f = tmp_path / "spiral.toml"
    f.write_text(design_to_toml(d))
    out_file = tmp_path / "best.toml"
    code = main(["assign", str(f), "--materials", "H-1,H-4,H-7", "--fixed", "h3=H-7", "--budget", "30",
                 "--workers", "1", "--json", "--write", str(out_file)])
    cap = capsys.readouterr()
    assert code == 0, cap.err
    out = json.loads(cap.out)
    assert out["search_space"] == 3 ** 2
    assert all(b["assignment"]["h3"] == "H-7" for b in out["best"])
    written = load_design(out_file)
    assert {h.id: h.material for h in written.hinges} == out["best"][0]["assignment"]
    assert simulate(written, method=Method.FCL).completed


@pytest.mark.parametrize("args, needle", [
    (["--fixed", "h7=H-1"], "no hinge 'h7'"),
    (["--fixed", "h1"], "HINGE=MATERIAL"),
    (["--materials", "H-1,VeroWhite"], "not a hinge material"),
    (["--objective", "fastest"], "--objective"),
    (["--top", "0"], "--top"),
    (["--temperature", "90", "--temperature-range", "80", "90"], "not both"),
])
def test_bad_assign_options_exit_2(tmp_path, capsys, args, needle):
    f = tmp_path / "spiral.toml"
    f.write_text(design_to_toml(_small_spiral()))
    assert main(["assign", str(f), *args]) == 2
    err = capsys.readouterr().err
    assert needle in err and err.count("\n") == 1


@pytest.mark.parametrize("command", [["assign"], ["robust", "--samples", "2"]])
def test_unreachable_scheduler_exit_2_names_the_address(capsys, monkeypatch, command):
    import foldprint.apps.distributed as dist

    # the refusal is the same at any wait; 0.5 s instead of the 5 s default keeps the suite quick
    monkeypatch.setattr(dist, "CONNECT_TIMEOUT_S", 0.5)
    addr = "tcp://127.0.0.1:9"  # discard port: nothing listens there
    assert main([command[0], "helix_graded", *command[1:], "--scheduler", addr]) == 2
    err = capsys.readouterr().err
    assert addr in err and "scheduler" in err and "within 0.5 s" in err and err.count("\n") == 1


class _Cluster:
    """A real Dask scheduler and worker, each its own process (the `dask scheduler` and
    `dask worker` programs), talking TCP on loopback: tasks are pickled and sent over the
    wire, as on a lab's cluster."""

    def __init__(self, tmp: Path):
        import subprocess
        import sys
        import time

        file = tmp / "scheduler.json"
        base = [sys.executable, "-m"]
        self.procs = [subprocess.Popen(base + ["distributed.cli.dask_scheduler", "--host", "127.0.0.1",
                                               "--port", "0", "--no-dashboard", "--scheduler-file", str(file)],
                                       stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)]
        deadline = time.monotonic() + 120
        while not file.exists() and time.monotonic() < deadline:
            time.sleep(0.2)
        self.procs.append(subprocess.Popen(base + ["distributed.cli.dask_worker", "--scheduler-file", str(file),
                                                   "--nthreads", "1", "--nworkers", "1", "--no-dashboard",
                                                   "--host", "127.0.0.1"],
                                           stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL))
        self.scheduler_address = json.loads(file.read_text())["address"]
        import distributed

        with distributed.Client(self.scheduler_address, timeout=120) as client:
            client.wait_for_workers(1, timeout=120)

    def close(self):
        for p in reversed(self.procs):
            p.terminate()
        for p in self.procs:
            try:
                p.wait(timeout=30)
            except Exception:  # noqa: BLE001 - a worker that does not stop is killed
                p.kill()


@pytest.fixture(scope="module")
def cluster(tmp_path_factory):
    pytest.importorskip("distributed")
    c = _Cluster(tmp_path_factory.mktemp("dask"))
    try:
        assert c.scheduler_address.startswith("tcp://127.0.0.1:")
        yield c
    finally:
        c.close()


def test_local_and_cluster_runs_agree(cluster, capsys, tmp_path):
    f = tmp_path / "spiral.toml"
    f.write_text(design_to_toml(_small_spiral()))
    args = ["assign", str(f), "--materials", "H-1,H-3,H-5,H-7", "--objective", "robust", "--top", "2",
            "--samples", "3", "--seed", "5", "--budget", "40", "--json"]
    assert main(args) == 0
    local = json.loads(capsys.readouterr().out)
    assert main(args + ["--scheduler", cluster.scheduler_address]) == 0
    remote = json.loads(capsys.readouterr().out)
    assert local == remote
    assert local["best"] and all(b["jam_probability"] is not None for b in local["best"])
    # robust: the same samples on the cluster give the same answer
    rob = ["robust", str(f), "--samples", "3", "--seed", "2", "--json"]
    assert main(rob) == 0
    a = json.loads(capsys.readouterr().out)
    assert main(rob + ["--scheduler", cluster.scheduler_address]) == 0
    assert json.loads(capsys.readouterr().out) == a


def test_assign_text_output(capsys, tmp_path):
    f = tmp_path / "spiral.toml"
    f.write_text(design_to_toml(_small_spiral()))
    assert main(["assign", str(f), "--materials", "H-2,H-6", "--budget", "20", "--workers", "1"]) == 0
    out = capsys.readouterr().out
    assert re.search(r"\d+ feasible assignment\(s\) in \d+ evaluations", out)
    assert "h1=H-" in out


def test_growing_waves_extend_the_folded_region_in_small_steps():
    """The robust search's children: "all the rest", then connected groups of at most
    ROBUST_WAVE_MAX hinges touching what is placed (anything at the root)."""
    from foldprint.apps.assign.waves import ROBUST_WAVE_MAX, hinge_adjacency, growing_waves

    graph = hinge_adjacency(load_design(resolve_design_path("helix_uniform")))
    every = frozenset(range(9))
    root = growing_waves(every, frozenset(), graph)
    assert root[0] == every and all(len(w) <= ROBUST_WAVE_MAX for w in root[1:])
    assert len(root) == 1 + 9 + 8  # every single hinge and every adjacent pair of the strip
    placed = frozenset({3, 4})
    kids = growing_waves(every - placed, placed, graph)
    assert kids[0] == every - placed
    assert set(kids[1:]) == {frozenset({2}), frozenset({5}), frozenset({1, 2}), frozenset({5, 6})}


def test_order_risk_matches_sampled_recovery_times(helix, lib):
    """order_risk's linearised chance that scatter swaps two hinges' half-recovery times,
    against the times of drawn hinges (the scatter model's per-hinge Tg, thickness and
    local heat transfer, and the bath and the part's heat transfer shared by both, through
    the recovery model); and its exact limits: a shared material counts 1/2 per pair."""
    import math

    import numpy as np

    from foldprint.simulation.timing import order_risk
    from foldprint.simulation.robust import default_scatter

    sc = default_scatter()
    assert order_risk(helix, lib, ["H-3"] * 9, 90.0, sc) == pytest.approx(18.0)
    from dataclasses import replace

    two = replace(helix, hinges=helix.hinges[:2], panels=helix.panels[:3])
    p_model = order_risk(two, lib, ["H-3", "H-4"], 90.0, sc)
    rng = np.random.default_rng(3)
    n, swaps = 40, 0
    for _ in range(n):
        t50 = []
        bath = 90.0 + sc.bath_sd_c * rng.standard_normal()
        h_part = math.exp(sc.h_shared_sigma_ln * rng.standard_normal())
        for name in ("H-3", "H-4"):
            m = lib[name]
            h = h_part * math.exp(sc.h_local_sigma_ln * rng.standard_normal())
            rec = replace(m.recovery, h_w_m2k=m.recovery.h_w_m2k * h)
            m = replace(m, tg_c=m.tg_c + sc.tg_sd_c * rng.standard_normal(), recovery=rec)
            t50.append(recovery_curve(m, bath, 0.8 + sc.thickness_sd_mm * rng.standard_normal(), 10.0).time_to(0.5))
        swaps += t50[1] < t50[0]
    assert 0.0 < p_model < 0.5
    # binomial sd at n = 40 is <= 0.08; the linearisation adds a little
    assert abs(swaps / n - p_model) < 0.2, (swaps / n, p_model)


@pytest.mark.slow
def test_robust_best_is_no_worse_than_the_papers_graded_helix(helix, monkeypatch):
    """Robust assignment is worth its cost: with its finalists confirmed under scatter, ``assign --objective robust``
    on the uniform helix at the design's 90 C bath finds an assignment that jams no more
    often than the paper's graded helix under the same draws (seed), and the estimate it
    reports is the one ``foldprint robust`` makes of the written design. Small budgets
    (a smaller pool, fewer samples) keep it quick; it can fail when the finalists are
    chosen badly."""
    import foldprint.apps.assign.search as A
    from foldprint.simulation.robust import jam_probability

    monkeypatch.setattr(A, "ROBUST_POOL", 16)
    monkeypatch.setattr(A, "ROBUST_SCREEN_SAMPLES", 6)
    monkeypatch.setattr(A, "ROBUST_FINALISTS", 6)
    n, seed = 24, 1
    r = assign(helix, objective="robust", top=1, budget=300, samples=n, seed=seed)
    best = r.best[0]
    written = with_materials(helix, best.materials, best.bath_c)
    again = jam_probability(written, n, seed)
    assert again.jam_probability == best.jam_probability
    graded = jam_probability(load_design(resolve_design_path("helix_graded")), n, seed)
    assert best.jam_probability <= graded.jam_probability
