"""The working arrays of :mod:`foldprint.physics.recovery.batch` and the relaxation sum
read from a table.

* **Working arrays**: a batch's blocks of the time axis are computed in flat arrays kept
  per thread from batch to batch (:func:`fresh_arrays`, :class:`Buffers`), seen as the
  shapes of each block length (:class:`Block`).
* **The relaxation table**: U(xi) = sum_b g_b exp(-xi / tau_b) depends only on the
  spectrum and the scalar xi, so it is tabulated once per spectrum at steps of
  :data:`~foldprint.core.constants.RELAXATION_TABLE_STEP` in ln xi
  (:func:`relaxation_table`) and read by linear interpolation (:func:`table_block`); the
  error bound is in :mod:`foldprint.physics.recovery.batch`'s docstring.
"""

from __future__ import annotations

import math
import threading
from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from ...core.constants import RELAXATION_TABLE_STEP
from ...model.materials import RecoveryParams
from .curve import spectrum

#: Exponent beyond which a series term or relaxation branch is dropped (exp(-50) = 2e-22).
CUT = 50.0


class Block:
    """The working arrays of a block of ``m`` times, each C-contiguous: (n, n_z, m),
    (n, m) and (n, n_z, m, 2) views of the flat buffers of :class:`Buffers`."""

    def __init__(self, flat: dict[str, np.ndarray], n: int, n_z: int, m: int):
        shapes = {"fo": (n, m), "arg": (n, m), "cut": (n, m), "r": (n, m), "c": (n, n_z, m, 2)}
        for name, a in flat.items():
            shape = shapes.get(name, (n, n_z, m))
            setattr(self, name, a[:math.prod(shape)].reshape(shape))


_SCRATCH = threading.local()  # each thread's flat working arrays, kept between batches


def fresh_arrays(size: int) -> dict[str, np.ndarray]:
    """Flat working arrays of ``size`` elements (``c`` of 2 x size)."""
    flat = {name: np.empty(size) for name in ("theta", "x", "e", "xi", "u", "rate", "fo", "arg", "r")}
    flat.update((name, np.empty(size, dtype=bool)) for name in ("keep", "cut"))
    flat["idx"], flat["c"] = np.empty(size, dtype=np.intp), np.empty(2 * size)
    return flat


def _scratch(size: int) -> dict[str, np.ndarray]:
    """:func:`fresh_arrays` arrays of at least ``size`` elements, reused from batch to batch (a
    fresh array's first writes cost page faults: ~0.5 ms a batch): at most a few x
    :data:`~foldprint.physics.recovery.batch.BLOCK_ELEMENTS` x 8 bytes held per thread."""
    flat = getattr(_SCRATCH, "flat", None)
    if flat is None or flat["x"].size < size:
        flat = _SCRATCH.flat = fresh_arrays(size)
    return flat


class Buffers:
    """The working arrays of a batch's blocks and their views for each block length."""

    def __init__(self, n: int, n_z: int, m: int):
        self.n, self.n_z = n, n_z
        self.flat = _scratch(n * n_z * m)
        self.views: dict[int, Block] = {}

    def block(self, m: int) -> Block:
        if m not in self.views:
            self.views[m] = Block(self.flat, self.n, self.n_z, m)
        return self.views[m]


@dataclass(frozen=True, eq=False)
class RelaxationTable:
    """The relaxation sum U(xi) = sum_b g_b exp(-xi / tau_b) of one spectrum (each branch
    exactly 0 past xi / tau_b = CUT, as in the exact sum) at the nodes ln xi = y0 + i h,
    read by linear interpolation in ln xi. Below the first node (xi < 1e-13 tau_1) it
    holds U there (the exact U differs by less than 1e-13); every node from ``zero_from``
    on (the last node before CUT tau_n, where U < 1e-22) is exactly 0, so U is exactly 0
    past CUT tau_n, where every branch is cut, as in the exact sum."""

    y0: float
    step: float
    zero_from: int
    nodes: np.ndarray  # (N, 2): U at each node and its change to the next node

    def __call__(self, xi: np.ndarray) -> np.ndarray:
        """U at ``xi`` (any shape, >= 0)."""
        xi = np.asarray(xi, float)
        v = Block(fresh_arrays(xi.size), 1, 1, xi.size)
        _table_values(xi.reshape(1, 1, -1), self, v)
        return v.u.reshape(xi.shape).copy()


@lru_cache(maxsize=32)
def _table(tau: tuple[float, ...], g: tuple[float, ...], step: float) -> RelaxationTable:
    tau_a, g_a = np.array(tau), np.array(g)
    y0 = math.log(1e-13 * tau_a[0])
    y = y0 + step * np.arange(int(math.ceil((math.log(CUT * tau_a[-1]) - y0) / step)) + 3)
    x = np.exp(y)[:, None] * (1.0 / tau_a)[None, :]
    u = np.sum(np.where(x <= CUT, g_a * np.exp(-np.minimum(x, CUT)), 0.0), axis=1)
    # 0 from the last node before CUT tau_n on (U < 1e-22 there): exactly 0 from CUT tau_n on
    zero_from = max(0, int(np.argmax(x[:, -1] > CUT)) - 1)
    u[zero_from:] = 0.0
    nodes = np.stack([u, np.diff(u, append=0.0)], axis=1)
    nodes.setflags(write=False)
    return RelaxationTable(y0, step, zero_from, nodes)


def relaxation_table(p: RecoveryParams, step: float = RELAXATION_TABLE_STEP) -> RelaxationTable:
    """The (cached) :class:`RelaxationTable` of ``p``'s spectrum, nodes ``step`` apart in ln xi."""
    tau, g = spectrum(p)
    return _table(tuple(map(float, tau)), tuple(map(float, g)), float(step))


def table_block(xi: np.ndarray, table: RelaxationTable, v: Block) -> None:
    """U(xi) (into ``v.u``) of a block (xi rising along its last axis) read from ``table``:
    nothing to read where every element is past the nodes that are all 0."""
    if np.min(xi[..., 0]) > math.exp(table.y0 + (table.zero_from + 1) * table.step) * (1.0 + 1e-9):
        v.u.fill(0.0)
    else:
        _table_values(xi, table, v)


def _table_values(xi: np.ndarray, table: RelaxationTable, v: Block) -> None:
    """U(xi) (into ``v.u``) read from ``table``, element by element: one log and one
    interpolation instead of a sum of exponentials."""
    u, w, f = v.u, v.x, v.e
    with np.errstate(divide="ignore"):
        np.log(xi, out=w)  # -inf at xi = 0: held at the first node
    w -= table.y0
    w *= 1.0 / table.step
    np.clip(w, 0.0, len(table.nodes) - 2, out=w)
    np.floor(w, out=f)
    np.copyto(v.idx, f, casting="unsafe")
    w -= f
    c = np.take(table.nodes, v.idx, axis=0, out=v.c)
    np.multiply(c[..., 1], w, out=u)
    u += c[..., 0]
