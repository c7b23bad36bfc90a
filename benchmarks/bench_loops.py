"""Closure tracking of a Monte-Carlo chunk: the array tracker against the tracker it
replaced, in the same run.

    python benchmarks/bench_loops.py [--repeat N] [--json PATH]
    python benchmarks/bench_loops.py --sizes 4,16,64
    python benchmarks/bench_loops.py --record before.pkl   # then, after a change:
    python benchmarks/bench_loops.py --against before.pkl


For each template, the first 16 of ``check``'s samples (its seed, 1x scatter, its time
step: one chunk of :func:`foldprint.simulation.robust.run_samples`) are folded as the
Monte-Carlo folds them, with the array tracker (:mod:`foldprint.physics.loops.tracker`)
and with the baseline: the replaced tracker (``tests/loop_reference.py``: one generator
per drive in lockstep, an SVD per Gauss-Newton step, a solve at every grid step) on the
replaced loop grid (each simulation time held twice), with the poses of every time (held
configurations included). Printed: CPU ms per sample of the
chunk (``run_samples``, after one warm-up chunk) and of its phases (recovery curves, loop
closure, the folds with their swept collision checks), the ratios old / new, and whether
the outcomes are the same. ``helix_graded`` (a strip: no loops) shows the strip path is
untouched (ratio ~1). ``--sizes`` instead times the closure tracking alone on chunks of
those sizes and splits it into a cost per evaluation of C and J (the point's share of the
evaluation, its Gauss-Newton kernel and bookkeeping) and a cost per round (the array code
of a round whatever its size), by least squares over the sizes: what a chunk of 16 pays for
its rounds. ``--record`` / ``--against`` instead save and compare, bit for bit, what the
tracker decides for ``check``'s first 64 samples of both loop templates (closed angles,
closures, events, evaluations and rounds per chunk, ``run_samples``' outcomes), tracked in
chunks of 16 and in reversed chunks of 8 (which must agree too): a change that should only
make the tracker cheaper must leave all of it unchanged. Each measurement is repeated
(default 3; the two alternate, each first in turn) and the median kept; CPU time (this
process) because other processes on a loaded machine slow wall time down; the load average
is printed.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from itertools import islice
from pathlib import Path
from statistics import median
from unittest import mock

from foldprint.core.constants import CHECK_DT_S, CHECK_SAMPLES, CHECK_SEED
from foldprint.core.modes import VERDICT_METHOD, HingeModel
from foldprint.io.load import load_design
from foldprint.io.templates import templates_dir
from foldprint.model import derived
from foldprint.model.materials import default_library
from foldprint.physics import hinge_drive
from foldprint.physics.hinge_drive import loop_dt, run_times, solve_loops_many
from foldprint.physics.loops.closure import LoopSolver
from foldprint.simulation import robust
from foldprint.simulation.scatter import default_scatter, iter_samples
from foldprint.simulation.simulate import simulate

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
from loop_reference import OldSolver, old_loop_grid, old_simulate_kinematics  # noqa: E402

TEMPLATES = ("miura_3x3", "cross_lock_uniform", "helix_graded")
CHUNK = 16


def _baseline():
    """The replaced tracker, loop grid and poses of every time, patched in."""
    from foldprint.simulation import simulate as simulate_module

    return (mock.patch.object(hinge_drive, "LoopSolver", OldSolver),
            mock.patch.object(hinge_drive.HingeDrive, "_loop_grid", old_loop_grid),
            mock.patch.object(simulate_module, "simulate_kinematics", old_simulate_kinematics))


def _chunk(design, samples) -> dict:
    """CPU ms per sample of one chunk and of its phases, and its outcomes."""
    lib, pt = default_library(), time.process_time
    args = (design, lib, samples, HingeModel.ARC, CHECK_DT_S, False, VERDICT_METHOD)
    c0 = pt()
    outcomes = robust.run_samples(args)
    c1 = pt()
    with derived.design_scope(design) as dd:
        drives = robust.sample_drives(dd, lib, samples, until_s=robust.run_end(dd, CHECK_DT_S))
        c2 = pt()
        solve_loops_many(drives, run_times(dd, CHECK_DT_S))
        c3 = pt()
        solver = drives[0].loops
        for x in drives:
            simulate(dd, dt=CHECK_DT_S, method=VERDICT_METHOD, hinge_model=HingeModel.ARC, drive=x)
        c4 = pt()
    ms = lambda a, b: (b - a) / len(samples) * 1e3  # noqa: E731
    counts = {"evaluations": solver.evaluations, "rounds": solver.rounds} if type(solver) is LoopSolver else {}
    return {"chunk": ms(c0, c1), "curves": ms(c1, c2), "loops": ms(c2, c3), "folds": ms(c3, c4), "outcomes": outcomes,
            **counts}


def measure(name: str, repeat: int) -> dict:
    d = load_design(templates_dir() / f"{name}.toml")
    samples = list(islice(iter_samples(d, default_scatter(), CHECK_SAMPLES, CHECK_SEED), CHUNK))
    runs: dict[str, list[dict]] = {"new": [], "old": []}
    for r in range(repeat + 1):  # the first round warms the caches and is dropped
        for key in (("new", "old") if r % 2 else ("old", "new")):  # alternate which runs first
            if key == "old":
                p, q, u = _baseline()
                with p, q, u:
                    got = _chunk(d, samples)
            else:
                got = _chunk(d, samples)
            if r:
                runs[key].append(got)
    out = {"design": name, "same_outcomes": all(a["outcomes"] == b["outcomes"] for a, b in zip(runs["new"], runs["old"])),
           "jams": sum(o.jammed for o in runs["new"][0]["outcomes"])}
    if "rounds" in runs["new"][0]:  # the array tracker's work for the chunk: C and J evaluations, rounds
        out["evaluations"], out["rounds"] = runs["new"][0]["evaluations"], runs["new"][0]["rounds"]
    for phase in ("chunk", "curves", "loops", "folds"):
        new, old = median(x[phase] for x in runs["new"]), median(x[phase] for x in runs["old"])
        out[phase] = {"new_ms": round(new, 1), "old_ms": round(old, 1), "ratio": round(old / new, 2) if new > 0 else None}
    return out


def scaling(name: str, sizes: list[int], repeat: int) -> dict:
    """CPU time of the closure tracking alone on chunks of ``sizes`` samples (median of
    ``repeat``, after a warm-up) and its least-squares split into ms = a * evaluations +
    b * rounds: ``a`` in us per evaluation, ``b`` in ms per round."""
    import numpy as np

    d, lib = load_design(templates_dir() / f"{name}.toml"), default_library()
    rows = []
    for n in sizes:
        samples = list(islice(iter_samples(d, default_scatter(), CHECK_SAMPLES, CHECK_SEED), n))
        cpu = []
        for _ in range(repeat + 1):
            with derived.design_scope(d) as dd:
                drives = robust.sample_drives(dd, lib, samples, until_s=robust.run_end(dd, CHECK_DT_S))
                c0 = time.process_time()
                solve_loops_many(drives, run_times(dd, CHECK_DT_S))
                cpu.append((time.process_time() - c0) * 1e3)
        s = drives[0].loops
        rows.append({"samples": n, "ms": round(median(cpu[1:]), 1), "evaluations": s.evaluations, "rounds": s.rounds})
    a = np.array([[r["evaluations"], r["rounds"]] for r in rows], float)
    (per_eval, per_round), *_ = np.linalg.lstsq(a, np.array([r["ms"] for r in rows]), rcond=None)
    return {"design": name, "sizes": rows, "us_per_evaluation": round(per_eval * 1e3, 1),
            "ms_per_round": round(per_round, 2)}


def _tracked(d, lib, samples, size: int, order) -> dict:
    """The closure tracker's answers for ``samples`` tracked in chunks of ``size`` taken in
    ``order`` (indices into samples): per sample its angles and events, per chunk its
    evaluations and rounds."""
    import numpy as np

    out, counts = {}, []
    with derived.design_scope(d) as dd:
        for a in range(0, len(order), size):
            idx = order[a:a + size]
            drives = robust.sample_drives(dd, lib, [samples[i] for i in idx], until_s=robust.run_end(dd, CHECK_DT_S))
            s = drives[0].loops
            e0, r0 = s.evaluations, s.rounds
            times = run_times(dd, CHECK_DT_S)
            solve_loops_many(drives, times)
            counts.append((s.evaluations - e0, s.rounds - r0))
            for i, x in zip(idx, drives):
                sol = x.solve_loops(times, loop_dt(times))  # the lockstep's answer, not solved again
                out[int(i)] = (np.array(sol.angles), sol.closure, sol.stuck, sol.locked_at, sol.dof)
    return {"answers": [out[i] for i in range(len(samples))], "counts": counts}


def answers(name: str, n: int = 4 * CHUNK) -> dict:
    """Everything the tracker decides for ``check``'s first ``n`` samples of ``name``:
    ``run_samples``'s outcomes chunk by chunk, the tracker's answers in chunks of CHUNK, and
    the same in chunks of CHUNK // 2 taken in reverse order (another chunk composition)."""
    import numpy as np

    d, lib = load_design(templates_dir() / f"{name}.toml"), default_library()
    samples = list(islice(iter_samples(d, default_scatter(), CHECK_SAMPLES, CHECK_SEED), n))
    args = lambda s: (d, lib, s, HingeModel.ARC, CHECK_DT_S, False, VERDICT_METHOD)  # noqa: E731
    outcomes = [robust.run_samples(args(samples[a:a + CHUNK])) for a in range(0, n, CHUNK)]
    return {"outcomes": outcomes, "chunks": _tracked(d, lib, samples, CHUNK, np.arange(n)),
            "other": _tracked(d, lib, samples, CHUNK // 2, np.arange(n)[::-1])}


def _apart(key: str, got: list, want: list) -> list[str]:
    """The samples whose tracked answers differ bit for bit (angles, closure, events)."""
    import numpy as np

    return [f"{key}: sample {i} differs (largest angle difference {np.abs(a[0] - b[0]).max():.3g} rad)"
            for i, (a, b) in enumerate(zip(got, want)) if not np.array_equal(a[0], b[0]) or a[1:] != b[1:]]


def differences(got: dict, want: dict | None = None) -> list[str]:
    """What differs bit for bit between the two chunk compositions of one :func:`answers`
    and, given ``want`` (another run's, e.g. of the code before a change), between the two:
    angles, closures, events, evaluations and rounds per chunk, outcomes."""
    out = _apart("chunks of 16 / reversed chunks of 8", got["chunks"]["answers"], got["other"]["answers"])
    if want is None:
        return out
    if got["outcomes"] != want["outcomes"]:
        out.append("run_samples outcomes differ")
    for key in ("chunks", "other"):
        g, w = got[key], want[key]
        if g["counts"] != w["counts"]:
            out.append(f"{key}: evaluations/rounds {g['counts']} != {w['counts']}")
        out += _apart(key, g["answers"], w["answers"])
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--json", type=Path, help="also write the results here")
    ap.add_argument("--sizes", help="instead: the tracking's cost per evaluation and per round, chunks of these sizes")
    ap.add_argument("--record", type=Path, help="instead: save the tracker's answers on 4 chunks of check samples")
    ap.add_argument("--against", type=Path, help="instead: compare them bit for bit with those --record saved")
    a = ap.parse_args(argv)
    load = os.getloadavg()[0]
    if a.record or a.against:
        import pickle

        got = {name: answers(name) for name in TEMPLATES[:2]}
        if a.record:
            a.record.write_bytes(pickle.dumps(got))
        want = pickle.loads(a.against.read_bytes()) if a.against else {}
        bad = [f"{n}: {m}" for n, v in got.items() for m in differences(v, want.get(n))]
        for name, v in got.items():
            print(f"{name:20s} evaluations, rounds per chunk: {v['chunks']['counts']}")
        print("\n".join(bad) or "the same answers, bit for bit, in both chunk compositions"
              + (f" and as in {a.against}" if a.against else ""))
        if a.record:
            print(f"saved to {a.record}")
        return 1 if bad else 0
    if a.sizes:
        sizes = [int(v) for v in a.sizes.split(",")]
        print(f"closure tracking alone, CPU ms per chunk (median of {a.repeat}); load average {load:.1f}")
        for name in TEMPLATES[:2]:
            got = scaling(name, sizes, a.repeat)
            for r in got["sizes"]:
                print(f"{name:20s} {r['samples']:4d} samples {r['ms']:8.1f} ms {r['evaluations']:7d} evaluations "
                      f"{r['rounds']:4d} rounds")
            print(f"{name:20s} {got['us_per_evaluation']} us per evaluation, {got['ms_per_round']} ms per round")
        return 0
    rows = [measure(n, a.repeat) for n in TEMPLATES]
    print(f"CPU ms per sample, chunk of {CHUNK} check samples (median of {a.repeat}); load average {load:.1f}")
    print(f"{'template':20s} {'phase':7s} {'new':>8s} {'old':>8s} {'old/new':>8s}")
    for row in rows:
        for phase in ("chunk", "curves", "loops", "folds"):
            v = row[phase]
            print(f"{row['design']:20s} {phase:7s} {v['new_ms']:8.1f} {v['old_ms']:8.1f} {v['ratio'] or 0:8.2f}")
        work = f", {row['evaluations']} evaluations in {row['rounds']} rounds" if "rounds" in row else ""
        print(f"{row['design']:20s} same outcomes: {row['same_outcomes']} ({row['jams']} of {CHUNK} jam{work})")
    if a.json:
        a.json.write_text(json.dumps({"load_average": round(load, 2), "chunk": CHUNK, "repeat": a.repeat, "rows": rows},
                                     indent=1) + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
