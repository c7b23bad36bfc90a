"""What a calibration fit costs (``foldprint calibrate``, :mod:`foldprint.physics.calibration.fit`),
estimated from the problem before the first residual is computed, and refused through
the guard (:func:`foldprint.core.guards.enforce`) over the memory limit or the time budget.

One residual evaluation makes the recovery curve of every (material, bath, thickness,
initial temperature) the rows use on the model's time grid (one array pass per material
and starting temperature), then reads every row off its curve (a Python loop). A fit
evaluates the residuals at each of its starts' steps and finite-difference Jacobians; the
profile likelihood re-fits the others at up to 7 values on each side of every parameter.
Memory: the curves (ratio and mean temperature while they are made, and the concatenated
batches), the Jacobian (rows x parameters) and one batch's temporaries.
"""

from __future__ import annotations

from ...core.guards import BASE_BYTES, LIFT_TIME, enforce, fmt_bytes, fmt_seconds, lift_memory_env
from ..recovery.batch import MAX_BATCH_ELEMENTS

# Measured with a synthetic CSV per dimension (one curve and 2,000 ratio rows, 50 curves,
# 200 time_to rows on 50 curves, 10 new materials; tests/test_guards_costs.py
# holds the estimate above a measured fit), CPU on the loaded 2-core machine, rounded up:
#: seconds of one evaluation: a fixed part, per row read off its curve at a time (ratio,
#: angle: one interpolation per curve, 8.6 ns a row measured on 100,000 rows), per row
#: read at a crossing (time_to, spread: one at a time, 3.8 us measured on 2,000 rows), per
#: curve point made (0.13 us), per curve group (one array pass per material and starting
#: temperature: 1.4 ms measured with its curve)
S_PER_EVALUATION = 0.5e-3
S_PER_ROW = 0.05e-6
S_PER_CROSSING_ROW = 5e-6
S_PER_CURVE_POINT = 0.15e-6
S_PER_GROUP = 1.0e-3
#: evaluations of the fit, per start and free parameter (measured 283 for 3 parameters
#: and 5 starts, 541 with 10 new materials: at most 27 per start and parameter + 1), and of
#: the profile per parameter and parameter + 1 (measured 240 more for 3 parameters: 20, rounded up)
EVALS_PER_START_PARAM = 30
PROFILE_EVALS_PER_PARAM2 = 25
#: bytes per curve point held while the curves are made: the ratio and the mean
#: temperature (8 B each), both again while the batches are concatenated, and the curve
#: kept (our choice from the code: 5 x 8 B)
BYTES_PER_CURVE_POINT = 40
#: one batch's temporaries (the relaxation sum over its elements: 10 floats an element)
BATCH_BYTES = MAX_BATCH_ELEMENTS * 8 * 10


def fit_estimate(problem, starts: int, with_profile: bool = True) -> dict:
    """Peak bytes and CPU seconds of fitting ``problem`` from ``starts`` + 1 starting points
    (the library's and ``starts`` more), with its profile intervals when ``with_profile``."""
    rows = float(len(problem.data.observations))
    crossing = float(sum(1 for o in problem.data.observations if o.kind in ("time_to", "spread")))
    keys = float(len(problem.curve_keys))
    groups = float(len({(k[0], k[3]) for k in problem.curve_keys}))
    nt = float(len(problem.t))
    n = float(len(problem.params))
    per_eval = (S_PER_EVALUATION + rows * S_PER_ROW + crossing * S_PER_CROSSING_ROW + keys * nt * S_PER_CURVE_POINT
                + groups * S_PER_GROUP)
    evals = (starts + 1) * EVALS_PER_START_PARAM * (n + 1) + (PROFILE_EVALS_PER_PARAM2 * n * (n + 1) if with_profile else 0)
    nbytes = BASE_BYTES + keys * nt * BYTES_PER_CURVE_POINT + BATCH_BYTES + rows * (n + 4) * 8 * 3
    return {"bytes": nbytes, "seconds": evals * per_eval, "evaluations": evals, "seconds_per_evaluation": per_eval,
            "curves": keys, "rows": rows, "grid": nt, "parameters": n}


def check_fit(problem, starts: int, with_profile: bool = True) -> dict:
    """Refuse a fit whose estimate (:func:`fit_estimate`) is over the memory limit or the
    time budget, before the first curve is made."""
    est = fit_estimate(problem, starts, with_profile)
    what = (f"{est['rows']:.0f} rows on {est['curves']:.0f} curves of {est['grid']:.0f} time points, "
            f"{est['parameters']:.0f} free parameters")
    fix = ("fit fewer curves at once (split the file by material or bath), hold parameters with --fix, or "
           "average repeated rows")
    return enforce(est, f"{problem.data.source}: calibrate",
                   (f"{what}: the curves need about {fmt_bytes(est['bytes'])}", f"{fix}; or {lift_memory_env(est)}"),
                   (f"{what}: about {est['evaluations']:.0f} evaluations of {fmt_seconds(est['seconds_per_evaluation'])} "
                    f"take about {fmt_seconds(est['seconds'])}", f"{fix}; or {LIFT_TIME}"))


# A DMA fit (physics/calibration/dma.py): one evaluation sums the Prony branches over every
# row (dynamic_mpa / relaxation_mpa) and finds the spectrum's centre that puts the 1 Hz
# tan-delta peak at Tg (a 0.05-decade grid and a bounded Brent search: the fixed part).
# Measured on a 92-row synthetic sweep (6 free parameters, 5 starts: 0.53 s for 88 counted
# evaluations, 7 function calls each with the Jacobian: 0.9 ms a call on the loaded 2-core
# machine), rounded up:
#: seconds of one evaluation: a fixed part and per row and branch
S_PER_DMA_EVALUATION = 2e-3
S_PER_DMA_ROW_BRANCH = 0.1e-6
#: the profile of a DMA fit walks :data:`~.profile.FINE_STEPS` (14 a side): twice the evaluations
DMA_PROFILE_FACTOR = 2


def dma_estimate(problem, starts: int, with_profile: bool = True) -> dict:
    """Peak bytes and CPU seconds of fitting one material's DMA rows (:class:`.dma.DmaProblem`)."""
    rows = float(len(problem.rows))
    branches = float(problem.template.recovery.n_branches)
    n = float(len(problem.params))
    per_eval = S_PER_DMA_EVALUATION + rows * branches * S_PER_DMA_ROW_BRANCH
    evals = (starts + 1) * EVALS_PER_START_PARAM * (n + 1) + (
        DMA_PROFILE_FACTOR * PROFILE_EVALS_PER_PARAM2 * n * (n + 1) if with_profile else 0)
    nbytes = BASE_BYTES + rows * branches * 8 * 8 + rows * (n + 4) * 8 * 3
    return {"bytes": nbytes, "seconds": evals * per_eval, "evaluations": evals, "seconds_per_evaluation": per_eval,
            "rows": rows, "parameters": n}


def check_dma_fits(problems, starts: int, with_profile: bool = True) -> dict:
    """Refuse DMA fits whose summed estimate (:func:`dma_estimate`) is over the memory limit or
    the time budget, before the first evaluation."""
    ests = [dma_estimate(p, starts, with_profile) for p in problems]
    est = {"bytes": max(e["bytes"] for e in ests), "seconds": sum(e["seconds"] for e in ests),
           "evaluations": sum(e["evaluations"] for e in ests), "rows": sum(e["rows"] for e in ests)}
    what = f"{est['rows']:.0f} DMA rows of {len(ests)} materials"
    fix = "fit fewer materials at once (split the file by material), or thin the sweep"
    return enforce(est, f"{problems[0].source}: calibrate",
                   (f"{what}: the fit needs about {fmt_bytes(est['bytes'])}", f"{fix}; or {lift_memory_env(est)}"),
                   (f"{what}: about {est['evaluations']:.0f} evaluations take about {fmt_seconds(est['seconds'])}",
                    f"{fix}; or {LIFT_TIME}"))
