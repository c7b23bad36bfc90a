"""The kernels' warm-up on a cold numba cache (foldprint.simulation.jamtest.warmup): its
groups cover every kernel module once and call no kernel of another group (so one worker
per group compiles each kernel once), a cold group is read from numba's cache, and the pool
gives each cold group its own worker before any chunk, with the same outcomes."""

from __future__ import annotations

import ast
import os
import subprocess
import sys
import time
from pathlib import Path

import pytest

import foldprint
from foldprint.core import jit
from foldprint.io.load import load_design
from foldprint.io.templates import templates_dir
from foldprint.simulation.jamtest import pool, warmup
from foldprint.simulation.jamtest.pool import MonteCarloJob, run_batch

PKG = Path(foldprint.__file__).parent


def _kernel_modules() -> set[str]:
    return {"foldprint." + ".".join(p.relative_to(PKG).with_suffix("").parts) for p in PKG.rglob("*_kernels.py")}


def _imported_kernels(module: str) -> set[str]:
    """The kernel modules ``module`` imports (relative imports resolved)."""
    path = PKG.joinpath(*module.split(".")[1:]).with_suffix(".py")
    pkg = module.rsplit(".", 1)[0].split(".")
    out = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.ImportFrom) and node.module:
            base = pkg[:len(pkg) - node.level + 1] if node.level else []
            name = ".".join(base + node.module.split("."))
            if name.endswith("_kernels"):
                out.add(name)
    return out


def test_the_groups_cover_every_kernel_module_once():
    listed = [m for mods in warmup.GROUPS.values() for m in mods]
    assert len(listed) == len(set(listed))
    assert set(listed) == _kernel_modules()


def test_no_kernel_of_a_group_calls_one_of_another():
    group_of = {m: g for g, mods in warmup.GROUPS.items() for m in mods}
    for m, g in group_of.items():
        for dep in _imported_kernels(m):
            assert group_of[dep] == g, f"{m} ({g}) imports {dep} ({group_of[dep]})"
    # the import reader sees the imports it must see
    assert "foldprint.collision.polytope_distance_kernels" in _imported_kernels("foldprint.collision.narrow_kernels")


def test_every_probe_is_a_compiled_kernel_of_its_group():
    if not jit.use_kernels():
        pytest.skip("numba cannot load here")
    import importlib

    from numba.core.registry import CPUDispatcher

    for g, probes in warmup.PROBES.items():
        assert probes
        for module, name in probes:
            assert module in warmup.GROUPS[g]
            assert isinstance(getattr(importlib.import_module(module), name), CPUDispatcher)


def _cold(tmp_path, loops: bool, kernels: str = "numba") -> list[str]:
    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path / "cache"), FOLDPRINT_KERNELS=kernels)
    code = f"from foldprint.simulation.jamtest.warmup import cold_groups; print(','.join(cold_groups({loops})))"
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, check=True)
    return [g for g in out.stdout.strip().split(",") if g]


def _run(tmp_path, code: str) -> str:
    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path / "cache"))
    return subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True,
                          check=True).stdout.strip()


def test_a_kernel_is_cached_once_compiled_in_another_process(tmp_path):
    if not jit.use_kernels():
        pytest.skip("numba cannot load here")
    probe = ("from foldprint.simulation.jamtest.warmup import is_cached; "
             "print(is_cached('foldprint.physics.recovery.batch_kernels', 'vexp'))")
    assert _run(tmp_path, probe) == "False"
    _run(tmp_path, "import numpy as np; from foldprint.physics.recovery.batch_kernels import vexp; "
                   "x = np.zeros(3); vexp(x, np.empty(3), np.empty(3, np.int64))")
    assert _run(tmp_path, probe) == "True"


def test_an_empty_cache_is_cold_and_the_numpy_path_never_is(tmp_path):
    if not jit.use_kernels():
        pytest.skip("numba cannot load here")
    assert _cold(tmp_path, True) == ["strips", "loops"]
    assert _cold(tmp_path, False) == []  # one group alone: left to the chunks
    assert _cold(tmp_path, True, "numpy") == []


def test_an_unknown_group_is_refused():
    with pytest.raises(ValueError, match="no kernel group 'gpu'"):
        warmup.warm_group("gpu")


_LOG = {"dir": None}


def _fake_warm(name: str) -> str:
    t0 = time.time()
    time.sleep(0.4)
    Path(_LOG["dir"], f"warm-{name}").write_text(f"{os.getpid()} {t0} {time.time()}")
    return name


def _logged_chunk(j, scatter, start, size):
    Path(_LOG["dir"], f"chunk-{os.getpid()}-{j}-{start}-{time.time()}").write_text("")
    return _CHUNK(j, scatter, start, size)


_CHUNK = pool._chunk_task


def test_the_pool_warms_each_cold_group_on_its_own_worker_before_any_chunk(tmp_path, monkeypatch):
    monkeypatch.setenv("FOLDPRINT_KERNELS", "numpy")  # the schedule, not the compiler
    designs = [load_design(templates_dir() / f"{n}.toml") for n in ("helix_uniform", "self_lock")]
    jobs = [MonteCarloJob(d, 24, 3) for d in designs]
    ref, _, _ = run_batch(jobs, workers=2)
    _LOG["dir"] = str(tmp_path)
    monkeypatch.setattr(pool, "cold_groups", lambda loops: ["strips", "loops"])
    monkeypatch.setattr(pool, "warm_group", _fake_warm)
    monkeypatch.setattr(pool, "_chunk_task", _logged_chunk)
    news = []
    got, _, _ = run_batch(jobs, workers=2, progress=lambda kind, what, _out: news.append((kind, what)))
    assert news.count(("warm", ("strips", "loops"))) == 1  # the user is told what the wait is
    assert [k for k, _ in news if k != "samples"] == ["warm"]
    warm = [tuple(map(float, (tmp_path / f"warm-{g}").read_text().split())) for g in ("strips", "loops")]
    assert warm[0][0] != warm[1][0]  # one worker each
    assert warm[0][1] < warm[1][2] and warm[1][1] < warm[0][2]  # at the same time
    chunks = [float(p.name.split("-", 4)[4]) for p in tmp_path.glob("chunk-*")]
    assert chunks and min(chunks) >= max(w[2] for w in warm)  # no chunk before both are back
    assert [p.outcomes for p in got] == [p.outcomes for p in ref]
