"""The memory guard holds (a large input is refused, never an out-of-memory kill): representative large designs of every input
kind through every command, each in a fresh interpreter under a 2 GiB address-space limit
(RLIMIT_AS: an allocation past it is a MemoryError, as on a machine that small). Each run
keeps the contract of ``fuzz_gen.contract_violations``: exit 0, 1 (the design fails) or 2
(refused with its estimate), never a kill, a traceback or a MemoryError, and a peak
resident size under the guard's 2 GiB. Before: a 1000-panel strip under ``check
--samples 0`` reached 6.5 GB (the clearance search held every pose-pair bound), a
1,500-face FOLD strip 3.6 GB, 16 Monte-Carlo samples of a 1000-hinge strip 1.3 GB of
curves at once (MemoryError under the limit), and a 150 x 150 SVG grid was refused only
after 40 CPU-s."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from fuzz_gen import contract_violations, run_fresh

from foldprint.simulation import costs

GiB = 2 ** 30


def _strip(n: int, angle: float) -> str:
    angles = [angle if k % 2 == 0 else -angle for k in range(n - 1)]
    return (f'schema = 1\nname = "s{n}"\n[strip]\nlengths_mm = {[10] * n}\nangles_deg = {angles}\n'
            f'materials = {["H-3"] * (n - 1)}\n').replace("'", '"')


def _fold_strip(n: int) -> str:
    xy = [[5 * i, 0] for i in range(n + 1)] + [[5 * i, 6] for i in range(n + 1)]
    return json.dumps({"file_spec": 1.2, "frame_unit": "mm", "vertices_coords": xy,
                       "faces_vertices": [[i, i + 1, n + 2 + i, n + 1 + i] for i in range(n)],
                       "edges_vertices": [[i, n + 1 + i] for i in range(1, n)],
                       "edges_assignment": ["V" if i % 2 else "M" for i in range(n - 1)],
                       "edges_foldAngle": [30 if i % 2 else -30 for i in range(n - 1)]})


def _svg_grid(n: int) -> str:
    lines = [f'<rect x="0" y="0" width="{n}" height="{n}" stroke="#000" fill="none"/>']
    for i in range(1, n):
        lines += [f'<line x1="{i}" y1="0" x2="{i}" y2="{n}" stroke="#00f"/>',
                  f'<line x1="0" y1="{i}" x2="{n}" y2="{i}" stroke="#f00"/>']
    return (f'<svg xmlns="http://www.w3.org/2000/svg" width="{n}mm" height="{n}mm" viewBox="0 0 {n} {n}">'
            + "".join(lines) + "</svg>")


FILES = {"s1000.toml": lambda: _strip(1000, 30.0), "s1000a10.toml": lambda: _strip(1000, 10.0),
         "s300.toml": lambda: _strip(300, 30.0), "f1500.fold": lambda: _fold_strip(1500),
         "grid150.svg": lambda: _svg_grid(150)}

# (command line, environment, the exit codes it may give): every command, every input kind
CASES = [
    (["check", "s1000.toml", "--samples", "0", "--json"], {}, (1,)),  # 9.4 m long: fails FP100
    (["simulate", "f1500.fold", "--json"], {}, (0, 1)),
    (["check", "grid150.svg", "--samples", "0"], {}, (2,)),  # 22,500 panels, refused before noding
    (["export", "s1000.toml", "--format", "stl", "--out", "out"], {}, (0,)),
    (["robust", "s1000a10.toml", "--samples", "2", "--json"], {}, (0,)),
    (["assign", "s1000.toml", "--budget", "2", "--workers", "1", "--json"], {}, (0, 1)),
    # 80 samples x 3 scales of a 300-panel strip do not fit a 10 s budget: refused after
    # the first chunk, with the measured rate
    (["gallery", "s300.toml", "--out", "gallery", "--jobs", "1"], {"FOLDPRINT_TIME_BUDGET": "10"}, (2,)),
]


@pytest.fixture(scope="module")
def designs(tmp_path_factory):
    d = tmp_path_factory.mktemp("large")
    for name, text in FILES.items():
        (d / name).write_text(text())
    return d


@pytest.mark.slow  # ~60 CPU-s for the seven runs: the large designs are the point
@pytest.mark.parametrize("argv, env, codes", CASES, ids=lambda v: " ".join(v[:2]) if isinstance(v, list) else "")
def test_large_designs_stay_under_the_guard_in_2_gib(designs, tmp_path, argv, env, codes):
    for name in FILES:
        (tmp_path / name).symlink_to(designs / name)
    res = run_fresh(argv, tmp_path, address_limit=2 * GiB, cpu_s=120, env=env)
    made = sorted(p.name for p in tmp_path.iterdir() if p.name not in FILES)
    bad = contract_violations(res, wrote_on_exit_2=res["code"] == 2 and made != [], warnings_banned=True,
                              wrote_outside=bool(set(made) - {"out", "gallery"}), peak_limit_mib=2 * GiB / 2 ** 20)
    assert bad == [] and res["code"] in codes, (argv, res["code"], bad, res["err"][-800:], made)


def test_a_monte_carlo_chunk_makes_its_curves_a_few_samples_at_a_time(monkeypatch):
    """The chunk's samples get their curves in batches of at most CURVE_BATCH_BYTES (one
    sample when even one is larger), and the outcomes are those of one batch."""
    from foldprint.io.load import load_design
    from foldprint.model.materials import default_library
    from foldprint.simulation import robust

    d = load_design(Path(__file__).resolve().parents[1] / "templates" / "helix_graded.toml")
    lib = default_library()
    smp = robust.draw_samples(d, robust.default_scatter(), 5, 3)
    whole = robust.run_samples((d, lib, smp, "arc", 0.05))
    sizes = []
    real = robust.sample_drives
    monkeypatch.setattr(robust, "sample_drives", lambda *a, **k: sizes.append(len(a[2])) or real(*a, **k))
    one_sample = 32 * len(d.hinges) * len(robust.grid_until(robust.run_end(d, 0.05)))
    monkeypatch.setattr(robust, "CURVE_BATCH_BYTES", 2 * one_sample)
    assert robust.run_samples((d, lib, smp, "arc", 0.05)) == whole
    assert sizes == [2, 2, 1]
    sizes.clear()
    monkeypatch.setattr(robust, "CURVE_BATCH_BYTES", 1)
    assert robust.run_samples((d, lib, smp, "arc", 0.05)) == whole and sizes == [1] * 5


def test_a_gallery_refused_after_it_started_leaves_no_folder_it_made(tmp_path, monkeypatch, capsys):
    """The real gallery, refused after its viewer files were staged (a design's samples
    refused by the guard): exit 2, one line, no folder it made (the output folder, its
    parents, the staging folder beside it); a folder that was there before stays as it was."""
    import foldprint.apps.gallery.runner as gallery
    from foldprint.core.guards import ResourceError
    from foldprint.cli.commands import main

    staged = []

    def refused(designs, out, *args, **kw):
        staged.append(sorted(p.name for p in (out / "viewer").iterdir()))
        raise ResourceError("s: --samples 80 refused")

    monkeypatch.setattr(gallery, "_build_all", refused)
    assert main(["gallery", "helix_graded", "--out", str(tmp_path / "new" / "g")]) == 2
    assert staged and staged[0] != []  # it had started writing
    assert list(tmp_path.iterdir()) == [] and capsys.readouterr().err.count("\n") == 1
    (tmp_path / "mine").mkdir()
    assert main(["gallery", "helix_graded", "--out", str(tmp_path / "mine")]) == 2
    (tmp_path / "theirs").mkdir()
    (tmp_path / "theirs" / "notes.txt").write_text("kept")
    assert main(["gallery", "helix_graded", "--out", str(tmp_path / "theirs"), "--force"]) == 2
    assert len(staged) == 3 and sorted(p.name for p in tmp_path.iterdir()) == ["mine", "theirs"]
    assert list((tmp_path / "mine").iterdir()) == []
    assert [p.name for p in (tmp_path / "theirs").iterdir()] == ["notes.txt"]


def _s(n):
    from foldprint.model.design import strip

    return strip(f"s{n}", [10.0] * n, [30.0 if k % 2 == 0 else -30.0 for k in range(n - 1)], ["H-3"] * (n - 1))


@pytest.fixture
def default_guards(monkeypatch):
    """The guards at their defaults, and a process whose callers hold nothing: these tests
    count held bytes exactly, and an earlier test in the same process (the studio's
    background jam test, under `pytest -n 2 --dist loadfile`) may still hold its
    evaluation's bytes for a moment after it ended. Wait for it (up to 30 s), then count
    in a fresh table."""
    import time

    from foldprint.core import guards

    t0 = time.monotonic()
    while guards.held_elsewhere() and time.monotonic() - t0 < 30.0:
        time.sleep(0.05)
    monkeypatch.setattr(guards, "_HOLDERS", {})
    monkeypatch.delenv("FOLDPRINT_MAX_MEMORY", raising=False)
    monkeypatch.delenv("FOLDPRINT_TIME_BUDGET", raising=False)
    guards.set_max_memory(None)
    yield guards
    guards.set_max_memory(None)


def test_runs_held_at_once_and_what_callers_hold_add_up(default_guards):
    guards = default_guards
    d = _s(50)
    one = costs.run_estimate(d, 0.01, None, "fcl")
    two = costs.run_estimate(d, 0.01, None, "fcl", runs=2)
    assert two["bytes"] - one["bytes"] == pytest.approx(one["trajectory_bytes"])
    assert costs.run_estimate(d, 0.01, None, "fcl", extra=5e6)["bytes"] == pytest.approx(one["bytes"] + 5e6)
    with guards.holding(3e6, "a"), guards.holding(4e6, "b"):
        with guards.holding(1e6, "a"):  # an owner's nested stage replaces its count
            assert guards.held_elsewhere() == 5e6
        assert costs.run_estimate(d, 0.01, None, "fcl")["bytes"] == pytest.approx(one["bytes"] + 7e6)
        guards.set_max_memory(int(one["bytes"] + 6e6))
        with pytest.raises(guards.ResourceError, match="of earlier results held"):
            costs.check_simulation(d, 0.01, None, "fcl")
    assert guards.held_elsewhere() == 0.0
    costs.check_simulation(d, 0.01, None, "fcl")  # fits once nothing is held
    with pytest.raises(guards.ResourceError, match=r"2 runs held at once: .* in all"):
        costs.check_simulation(d, 0.01, None, "fcl", runs=2)


def test_an_evaluation_counts_what_it_keeps_in_every_later_run(default_guards, monkeypatch):
    """simulate's comparison runs beside the kept fold: its guard sees the fold's bytes,
    which are the arrays the result holds (and the estimate bounds them)."""
    from foldprint.apps.pipeline import EvalOptions, Evaluation

    guards = default_guards
    d = _s(40)
    seen = []
    real = costs.check_simulation
    monkeypatch.setattr(costs, "check_simulation",
                        lambda *a, **k: seen.append(guards.held_elsewhere()) or real(*a, **k))
    ev = Evaluation(d, EvalOptions(method="fcl"))
    ev.simulation_json()
    kept = ev.simulation.nbytes
    assert ev.held_bytes == kept > 0
    assert seen[-1] == kept  # the comparison's own guard, inside simulate()
    est = costs.run_estimate(d, ev.options.dt, None, "fcl")
    assert kept <= est["trajectory_bytes"] <= 4 * kept


def test_simulate_is_refused_up_front_when_its_two_runs_do_not_fit(default_guards, monkeypatch, tmp_path, capsys):
    """One run fits, the fold and its comparison do not: refused before the first fold."""
    import foldprint.apps.evaluation_nominal as evaluation_nominal
    from foldprint.cli.commands import main
    from foldprint.io.design_io import design_to_toml

    guards = default_guards
    d = _s(60)
    f = tmp_path / "s60.toml"
    f.write_text(design_to_toml(d))
    skip = costs.index2d_skip_reason
    one = costs.run_estimate(d, 0.01, None, "fcl")["bytes"]
    two = costs.run_estimate(d, 0.01, None, "fcl", runs=2)["bytes"]
    limit = int((one + two) / 2)
    guards.set_max_memory(limit)
    assert skip(d, 0.01, None)  # the index does not fit either: both runs are the 3D check's

    def boom(*a, **k):
        raise AssertionError("simulated despite the refusal")

    monkeypatch.setattr(evaluation_nominal, "simulate", boom)
    assert main(["simulate", str(f), "--max-memory", str(limit), "--json"]) == 2
    err = capsys.readouterr().err
    assert "2 runs held at once" in err and err.count("\n") == 1
