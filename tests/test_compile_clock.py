"""The time guards extrapolate CPU that is not compilation (``core.jit.work_cpu_s``): on a
cold numba cache a worker's first chunk compiles the kernels it meets, and timed with it a
20 s gallery run was estimated at 257 s and refused."""

import time

import pytest

from foldprint.core import jit

numba = pytest.importorskip("numba")


@pytest.mark.skipif(not jit.use_kernels(), reason="the numpy path compiles nothing")
def test_compilation_is_not_counted_as_work():
    # a function numba has never seen (no cache): calling it compiles it here
    def poly(x):  # pragma: no cover - compiled
        s = 0.0
        for k in range(20):
            s = s * x + k
        return s

    fn = numba.njit(poly)
    cpu0, work0 = time.process_time(), jit.work_cpu_s()
    fn(1.5)
    cpu, work = time.process_time() - cpu0, jit.work_cpu_s() - work0
    assert cpu > 0.02  # a compilation: tens of milliseconds at least
    assert work < 0.2 * cpu, (cpu, work)
    # plain work is counted in full
    cpu0, work0 = time.process_time(), jit.work_cpu_s()
    t_end = time.process_time() + 0.05
    while time.process_time() < t_end:
        pass
    cpu, work = time.process_time() - cpu0, jit.work_cpu_s() - work0
    assert work == pytest.approx(cpu, rel=0.05)
