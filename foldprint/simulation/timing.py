"""Timing under scatter: how likely the scatter model swaps the order in which hinges
recover, without simulating a fold. ``foldprint assign --objective robust`` ranks its
pool with :func:`order_risk` (docs/assign.md); the Monte-Carlo of the printed part
decides."""

from __future__ import annotations

import math
from dataclasses import replace
from functools import lru_cache
from typing import Sequence

import numpy as np

from ..model.design import Design
from ..model.materials import Material, MaterialLibrary
from ..physics.recovery.curve import recovery_curve
from .scatter import Scatter


#: The curves of :func:`_log_times` are made up to this horizon (s) first: their points
#: are the first of the whole horizon's, bit for bit, so the times read are the same, and
#: a third of the points. Only a curve that has not reached 98 % by then is made to the
#: whole horizon. Our choice: a bath run's 20 s.
FIRST_HORIZON_S = 20.0


def _log_times(material, bath_c: float, thickness: float, fix_c: float) -> np.ndarray:
    """ln of the times (s) to half and to full (98 %) recovery (inf when not reached)."""
    c = recovery_curve(material, bath_c, thickness, fix_c, horizon_s=FIRST_HORIZON_S)
    if c.fold_time is None:
        c = recovery_curve(material, bath_c, thickness, fix_c)
    return np.array([math.log(x) if x else math.inf for x in (c.time_to(0.5), c.fold_time)])


@lru_cache(maxsize=256)
def _time_spread(m: Material, bath_c: float, thickness: float, fix_c: float,
                 scatter: Scatter) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """ln t50 and ln t98 of a hinge of material ``m`` and, by finite differences, their
    variances under the per-hinge components of the scatter model (Tg, thickness, local
    h) and their shifts per sd of the shared ones (rows: bath temperature, the part's h;
    every hinge of a sample sees the same draw of these)."""
    base = _log_times(m, bath_c, thickness, fix_c)
    with np.errstate(invalid="ignore"):
        d_tg = (_log_times(replace(m, tg_c=m.tg_c + 0.5), bath_c, thickness, fix_c) - base) / 0.5
        d_th = (_log_times(m, bath_c, thickness + 0.02, fix_c) - base) / 0.02
        rec = replace(m.recovery, h_w_m2k=m.recovery.h_w_m2k * math.exp(0.1))
        d_h = (_log_times(replace(m, recovery=rec), bath_c, thickness, fix_c) - base) / 0.1
        d_b = (_log_times(m, bath_c + 0.5, thickness, fix_c) - base) / 0.5
    var = ((d_tg * scatter.tg_sd_c) ** 2 + (d_th * scatter.thickness_sd_mm) ** 2
           + (d_h * scatter.h_local_sigma_ln) ** 2)
    shared = np.array([d_b * scatter.bath_sd_c, d_h * scatter.h_shared_sigma_ln])
    return base, np.nan_to_num(var), np.nan_to_num(shared)


def _phi_upper(z: float) -> float:
    """P(N(0, 1) > z)."""
    return 0.5 * math.erfc(z / math.sqrt(2.0))


def order_risk(design: Design, lib: MaterialLibrary, materials: Sequence[str], bath_c: float,
               scatter: Scatter) -> float:
    """A ranking proxy for the ``robust`` pool (it knows nothing of the geometry; the
    Monte-Carlo decides): the expected number of hinge pairs whose order of half recovery
    scatter swaps, Phi(-|ln t50_i - ln t50_j| / sd) per pair with sd from a linearised
    scatter model (:func:`_time_spread`; a shared component moves both hinges, so only the
    difference of its effects counts), so a pair sharing a material counts 1/2; plus,
    weighted by the number of pairs, the chance that some hinge misses 98 % within the
    run. Lower is more robust."""
    fix_c = design.process.fix_temperature_c
    thick = min(h.thickness for h in design.hinges)
    spread = [_time_spread(lib[m], float(bath_c), thick, fix_c, scatter) for m in materials]
    n = len(spread)
    pairs = n * (n - 1) / 2
    log_dur = math.log(float(design.process.duration_s))
    done = 1.0
    for lt, var, shared in spread:
        if not math.isfinite(lt[1]):
            return 2 * pairs + 1
        sd = math.sqrt(var[1] + float(np.sum(shared[:, 1] ** 2)))
        done *= 1.0 - (_phi_upper((log_dur - lt[1]) / sd) if sd > 0 else float(lt[1] > log_dur))
    risk = pairs * (1.0 - done)
    for a in range(n):
        for b in range(a + 1, n):
            (la, va, ba), (lb, vb, bb) = spread[a], spread[b]
            sd = math.sqrt(va[0] + vb[0] + float(np.sum((ba[:, 0] - bb[:, 0]) ** 2)))
            risk += 0.5 if sd == 0 else _phi_upper(abs(la[0] - lb[0]) / sd)
    return risk
