"""The compiled kernels against the numpy reference path, in the same run.

    python benchmarks/bench_kernels.py [--repeat 3] [--checks helix_graded,miura_3x3]
                                       [--compare-check TEMPLATES|all] [--json]

Per template (helix_uniform, helix_graded, mailbox, miura_3x3): CPU ms per sample of one
chunk of 16 of ``check``'s samples through :func:`foldprint.simulation.robust.run_samples`
(after a warm-up chunk; median of ``--repeat``; the two paths alternate, each first in
turn), split into the recovery curves (``sample_drives``) and the rest (loops, kinematics,
swept check); the work a sample holds (curve elements: hinge strips x grid times x layer
pairs; hinge transforms: times x tree hinges; FCL distance calls) and whether the outcomes
are the same. Then ``foldprint check NAME --json`` as a fresh process on each path (wall
and CPU seconds, its pool included), and the kernels' compilation: one sample folded in a
fresh process with an empty numba cache (``NUMBA_CACHE_DIR``), again with that cache
filled, and on the numpy path. ``--compare-check`` runs ``check --json`` of those
templates on both paths and lists what differs (numbers beyond a relative 1e-9, any
string). CPU time because other processes on a loaded machine slow wall time down; the
load average is recorded. ``--json`` writes ``docs/data/bench_kernels.json``.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import tempfile
import time
from itertools import islice
from pathlib import Path
from statistics import median
from unittest import mock

ROOT = Path(__file__).resolve().parent.parent
DATA = ROOT / "docs" / "data" / "bench_kernels.json"
TEMPLATES = ("helix_uniform", "helix_graded", "mailbox", "miura_3x3")
CHUNK = 16
PATHS = ("numpy", "numba")


def _counted():
    """Patches counting the work of a chunk: curve elements, hinge transforms, FCL calls."""
    from foldprint.collision.swept3d import SweptChecker
    from foldprint.physics import kinematics
    from foldprint.physics.recovery import batch
    from foldprint.physics.recovery.curve import N_LAYERS

    count = {"curve_elements": 0, "transforms": 0, "fcl_calls": 0}
    curves, fwd, gap = batch._curves, kinematics.forward, SweptChecker.gap  # noqa: SLF001 -- counted

    def b(p, slab, tg, bath, initial_c, t, table):
        count["curve_elements"] += len(tg) * len(t) * N_LAYERS // 2  # a batch's parts, each once
        return curves(p, slab, tg, bath, initial_c, t, table)

    def f(design, angles, *a, **k):
        import numpy as np

        count["transforms"] += np.atleast_2d(angles).shape[0] * len(design.hinges)
        return fwd(design, angles, *a, **k)

    def g(self, *a):
        count["fcl_calls"] += 1
        return gap(self, *a)

    from foldprint.collision import swept_search
    from foldprint.physics import hinge_drive

    walk = swept_search.walk

    def w(checker, *a):  # the compiled narrow phase's distances (its kernel counts them)
        before = checker.n_distance_calls
        out = walk(checker, *a)
        count["fcl_calls"] += checker.n_distance_calls - before
        return out

    return count, (mock.patch.object(batch, "_curves", b), mock.patch.object(hinge_drive, "forward", f),
                   mock.patch.object(SweptChecker, "gap", g), mock.patch.object(swept_search, "walk", w))


def _fold(d, samples):
    """``run_samples`` on ``samples`` as ``check`` folds them."""
    from foldprint.core.constants import CHECK_DT_S
    from foldprint.core.modes import VERDICT_METHOD, HingeModel
    from foldprint.model.materials import default_library
    from foldprint.simulation import robust

    return robust.run_samples((d, default_library(), samples, HingeModel.ARC, CHECK_DT_S, False, VERDICT_METHOD))


def _chunk(d, samples) -> dict:
    from foldprint.core.constants import CHECK_DT_S
    from foldprint.core.modes import VERDICT_METHOD, HingeModel
    from foldprint.model import derived
    from foldprint.model.materials import default_library
    from foldprint.simulation import robust

    lib, pt = default_library(), time.process_time
    args = (d, lib, samples, HingeModel.ARC, CHECK_DT_S, False, VERDICT_METHOD)
    c0 = pt()
    out = robust.run_samples(args)
    c1 = pt()
    with derived.design_scope(d) as dd:
        robust.sample_drives(dd, lib, samples, until_s=robust.run_end(dd, CHECK_DT_S))
    c2 = pt()
    ms = lambda a, b: (b - a) / len(samples) * 1e3  # noqa: E731
    return {"sample_ms": ms(c0, c1), "curves_ms": ms(c1, c2), "outcomes": out}


def sample_cost(name: str, repeat: int) -> dict:
    from foldprint.core.constants import CHECK_SAMPLES, CHECK_SEED
    from foldprint.io.load import load_design
    from foldprint.io.templates import templates_dir
    from foldprint.simulation.scatter import default_scatter, iter_samples

    d = load_design(templates_dir() / f"{name}.toml")
    samples = list(islice(iter_samples(d, default_scatter(), CHECK_SAMPLES, CHECK_SEED), CHUNK))
    runs: dict[str, list[dict]] = {p: [] for p in PATHS}
    work = {}
    for r in range(repeat + 1):  # the first round warms caches (and compiles) and is dropped
        for path in (PATHS if r % 2 else PATHS[::-1]):
            with mock.patch.dict(os.environ, {"FOLDPRINT_KERNELS": path}):
                got = _chunk(d, samples)
                if r == 0:  # the work of run_samples alone
                    count, patches = _counted()
                    with patches[0], patches[1], patches[2], patches[3]:
                        _fold(d, samples)
                    work[path] = {k: v / CHUNK for k, v in count.items()}
            if r:
                runs[path].append(got)
    key = lambda o: (o.jammed, o.reason, o.pair)  # noqa: E731
    a_out, b_out = runs["numpy"][0]["outcomes"], runs["numba"][0]["outcomes"]
    dt = [abs(u - v) for x, y in zip(a_out, b_out) for u, v in ((x.time, y.time), (x.fold_time, y.fold_time))
          if u is not None and v is not None]
    out = {"design": name, "same_outcomes": [key(o) for o in a_out] == [key(o) for o in b_out],
           "max_time_difference_s": max(dt, default=0.0),
           "jams": sum(o.jammed for o in runs["numba"][0]["outcomes"]), "work_per_sample": work}
    for key in ("sample_ms", "curves_ms"):
        a, b = median(x[key] for x in runs["numpy"]), median(x[key] for x in runs["numba"])
        out[key] = {"numpy": round(a, 2), "numba": round(b, 2), "ratio": round(a / b, 2) if b else None}
    return out


def _run(argv: list[str], env: dict) -> tuple[float, float, subprocess.CompletedProcess]:
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    proc = subprocess.run(argv, capture_output=True, text=True, env=env, timeout=3600)
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return wall, (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime), proc


def check_wall(name: str, path: str) -> dict:
    env = dict(os.environ, FOLDPRINT_KERNELS=path)
    wall, cpu, proc = _run([sys.executable, "-m", "foldprint", "check", name, "--json"], env)
    return {"wall_s": round(wall, 2), "cpu_s": round(cpu, 2), "exit": proc.returncode, "json": proc.stdout}


_ONE_SAMPLE = """
import time
t0 = time.perf_counter(); c0 = time.process_time()
from itertools import islice
from foldprint.core.constants import CHECK_DT_S, CHECK_SAMPLES, CHECK_SEED
from foldprint.core.modes import VERDICT_METHOD, HingeModel
from foldprint.io.load import load_design
from foldprint.io.templates import templates_dir
from foldprint.model.materials import default_library
from foldprint.simulation import robust
from foldprint.simulation.scatter import default_scatter, iter_samples
d = load_design(templates_dir() / "helix_graded.toml")
s = list(islice(iter_samples(d, default_scatter(), CHECK_SAMPLES, CHECK_SEED), 1))
robust.run_samples((d, default_library(), s, HingeModel.ARC, CHECK_DT_S, False, VERDICT_METHOD))
print(time.perf_counter() - t0, time.process_time() - c0)
"""


def compile_cost() -> dict:
    """One helix_graded sample in a fresh process: with an empty numba cache (every
    kernel compiled), with the cache that run filled, and on the numpy path."""
    out = {}
    with tempfile.TemporaryDirectory() as cache:
        for key, path in (("cold_cache", "numba"), ("warm_cache", "numba"), ("numpy_path", "numpy")):
            env = dict(os.environ, FOLDPRINT_KERNELS=path, NUMBA_CACHE_DIR=cache)
            _, _, proc = _run([sys.executable, "-c", _ONE_SAMPLE], env)
            wall, cpu = (float(x) for x in proc.stdout.split())
            out[key] = {"wall_s": round(wall, 2), "cpu_s": round(cpu, 2)}
    out["compile_cpu_s"] = round(out["cold_cache"]["cpu_s"] - out["warm_cache"]["cpu_s"], 2)
    out["cache_load_cpu_s"] = round(out["warm_cache"]["cpu_s"] - out["numpy_path"]["cpu_s"], 2)
    return out


def differences(a, b, where: str = "", rel: float = 1e-9) -> list[str]:
    """What differs between two JSON values: numbers beyond ``rel``, anything else."""
    if isinstance(a, dict) and isinstance(b, dict):
        if set(a) != set(b):
            return [f"{where}: keys {sorted(set(a) ^ set(b))}"]
        return [x for k in a for x in differences(a[k], b[k], f"{where}.{k}", rel)]
    if isinstance(a, list) and isinstance(b, list):
        if len(a) != len(b):
            return [f"{where}: {len(a)} against {len(b)} items"]
        return [x for i, (u, v) in enumerate(zip(a, b)) for x in differences(u, v, f"{where}[{i}]", rel)]
    if isinstance(a, (int, float)) and isinstance(b, (int, float)) and not isinstance(a, bool):
        return [] if abs(a - b) <= rel * max(abs(a), abs(b), 1e-300) else [f"{where}: {a!r} against {b!r}"]
    return [] if a == b else [f"{where}: {a!r} against {b!r}"]


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--templates", default=",".join(TEMPLATES))
    ap.add_argument("--checks", default="helix_graded,miura_3x3")
    ap.add_argument("--compare-check", default="", help="templates (or 'all') whose check --json to compare")
    ap.add_argument("--json", action="store_true", help=f"write {DATA.relative_to(ROOT)}")
    a = ap.parse_args()
    res: dict = {"load_average_start": [round(x, 2) for x in os.getloadavg()], "chunk": CHUNK,
                 "repeat": a.repeat, "samples": [], "checks": {}, "check_json_differences": {}}
    for name in filter(None, a.templates.split(",")):
        r = sample_cost(name, a.repeat)
        res["samples"].append(r)
        print(f"{name}: sample {r['sample_ms']} ms, curves {r['curves_ms']} ms, same outcomes "
              f"{r['same_outcomes']}, work {r['work_per_sample']['numba']}", flush=True)
    for name in filter(None, a.checks.split(",")):
        got = {p: check_wall(name, p) for p in PATHS}
        res["checks"][name] = {p: {k: v for k, v in g.items() if k != "json"} for p, g in got.items()}
        res["check_json_differences"][name] = differences(json.loads(got["numpy"]["json"]),
                                                          json.loads(got["numba"]["json"]))
        print(f"check {name}: {res['checks'][name]}; differences {res['check_json_differences'][name]}", flush=True)
    names = a.compare_check.split(",") if a.compare_check != "all" else \
        sorted(p.stem for p in (ROOT / "templates").glob("*.toml"))
    for name in filter(None, names):
        if name in res["check_json_differences"]:
            continue
        got = {p: check_wall(name, p) for p in PATHS}
        res["check_json_differences"][name] = differences(json.loads(got["numpy"]["json"]),
                                                          json.loads(got["numba"]["json"]))
        print(f"check {name} --json: {len(res['check_json_differences'][name])} differences", flush=True)
    res["compilation"] = compile_cost()
    print(f"compilation: {res['compilation']}")
    res["load_average_end"] = [round(x, 2) for x in os.getloadavg()]
    if a.json:
        DATA.write_text(json.dumps(res, indent=1) + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
