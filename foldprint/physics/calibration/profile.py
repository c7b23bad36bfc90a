"""What a calibration can say: per-parameter intervals from the profile likelihood, the
residual of every measured curve, and the parameters the data do not fix (at a bound,
or free along a whole side of their range), each with the measurement that would fix it.

Profile likelihood (e.g. Raue et al., Bioinformatics 2009): for one parameter held at a
value, the others are fitted again; the 95 % interval is where the best chi2 stays within
chi2.ppf(0.95, 1) = 3.84 of the optimum (times chi2/dof when the model misses the data
beyond their stated uncertainty). An interval that runs into a bound before chi2 rises
that much is open on that side: the data do not identify the parameter there.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ...model.paper_reading import Reading, read
from .fit import Fit, Problem, solve

#: Where the profile is evaluated on each side: fractions of the way from the optimum to
#: the bound (numerical choice; the crossing is interpolated between two of them).
STEPS = (0.03, 0.08, 0.16, 0.3, 0.5, 0.75, 1.0)
#: Steps for data that pin a parameter to a small part of its range (a DMA sweep pins Tg to
#: a fraction of a degree in a box of tens): from 1e-5 of the way on, about 3x apart, with
#: the crossing interpolated in sqrt(delta chi2), exact for a quadratic profile.
FINE_STEPS = (1e-5, 3e-5, 1e-4, 3e-4, 1e-3, 3e-3, 0.01, 0.03, 0.08, 0.16, 0.3, 0.5, 0.75, 1.0)
#: A parameter within this share of its range of a bound is "at" it; within NEAR_BOUND,
#: "next to" it (our choices, for the messages).
AT_BOUND = 1e-3
NEAR_BOUND = 0.1
#: A row the optimum misses by more than this many of its sigmas is named in the findings
#: (our choice: two sigma, outside ~95 % of a row's normal scatter).
MISS_SIGMA = 2.0


@dataclass(frozen=True)
class Interval:
    """The profile-likelihood interval of one parameter; ``open_low`` / ``open_high``: the
    profile reached that bound still inside the threshold (not identified on that side)."""

    label: str
    value: float
    low: float
    high: float
    open_low: bool
    open_high: bool
    at_bound: str | None  # "lower", "upper" or None
    points: tuple  # (value, delta chi2) evaluated, for plots and reports
    no_dof: bool = False  # the fit had no degrees of freedom left: the profile cannot identify

    @property
    def identified(self) -> str:
        """"yes", "one side" or "no" ("no" whenever the fit had no degrees of freedom)."""
        if self.no_dof:
            return "no"
        n = int(self.open_low) + int(self.open_high)
        return ("yes", "one side", "no")[n]

    @property
    def why(self) -> str:
        """Why :attr:`identified` is not "yes" ("" when it is)."""
        if self.no_dof:
            return NO_DOF_WHY
        return {"one side": "open on one side: the profile reaches a bound within the threshold",
                "no": "open on both sides: the profile reaches both bounds within the threshold"}.get(
                    self.identified, "")


#: Why a fit with no degrees of freedom identifies nothing.
NO_DOF_WHY = ("no degrees of freedom left (as many free parameters as rows or more): with nothing over to "
              "measure the scatter by, the threshold of the profile means nothing")


def at_bound(problem: Problem, fit: Fit, j: int) -> str | None:
    """"lower" or "upper" when free parameter ``j`` sits on that bound, else None."""
    lo, hi = problem.lower[j], problem.upper[j]
    if fit.x[j] - lo <= AT_BOUND * (hi - lo):
        return "lower"
    return "upper" if hi - fit.x[j] <= AT_BOUND * (hi - lo) else None


def threshold(fit: Fit, confidence: float) -> float:
    from scipy.stats import chi2

    return float(chi2.ppf(confidence, 1)) * fit.scale


def _side(problem: Problem, fit: Fit, j: int, bound: float, thr: float, max_nfev: int, steps=STEPS,
          fine: bool = False):
    """Walk parameter ``j`` from the optimum to ``bound``: (end, open, points); ``fine``:
    the crossing interpolated in sqrt(delta chi2) (else in delta chi2)."""
    x_opt = fit.x[j]
    free = np.ones(len(fit.x), bool)
    free[j] = False
    x, prev = fit.x.copy(), (x_opt, 0.0)
    points = []
    for frac in steps:
        v = x_opt + frac * (bound - x_opt)
        x[j] = v
        if free.any():
            x, _ = solve(problem, x, free, max_nfev)
        r = problem.residuals(x)
        d = float(r @ r) - fit.chi2
        points.append((float(v), d))
        if d > thr:
            (v0, d0) = prev
            if fine:
                d0, d, thr_ = np.sqrt(d0), np.sqrt(d), np.sqrt(thr)
            else:
                thr_ = thr
            end = v0 + (thr_ - d0) / (d - d0) * (v - v0) if d != d0 else v
            return float(end), False, points
        prev = (v, max(d, 0.0))
    return float(bound), True, points


def profile(problem: Problem, fit: Fit, confidence: float | None = None, fine: bool = False) -> tuple[Interval, ...]:
    """Profile-likelihood intervals of every free parameter (each side re-fits the others
    at up to ``len(STEPS)`` values; ``fine``: at :data:`FINE_STEPS`)."""
    conf = problem.config.confidence if confidence is None else confidence
    thr = threshold(fit, conf)
    lo, hi = problem.lower, problem.upper
    out = []
    max_nfev = 30 * len(fit.x)
    for j, p in enumerate(problem.params):
        at = at_bound(problem, fit, j)
        ends, opens, pts = [], [], []
        for bound, is_at in ((lo[j], at == "lower"), (hi[j], at == "upper")):
            if is_at:
                ends.append(float(bound))
                opens.append(True)
                continue
            e, o, ps = _side(problem, fit, j, float(bound), thr, max_nfev, FINE_STEPS if fine else STEPS, fine)
            ends.append(e)
            opens.append(o)
            pts += ps
        pts.append((float(fit.x[j]), 0.0))
        out.append(Interval(p.label, float(fit.x[j]), ends[0], ends[1], opens[0], opens[1], at,
                            tuple(sorted(pts)), fit.dof <= 0))
    return tuple(out)


def curve_residuals(problem: Problem, fit: Fit) -> list[dict]:
    """Per measured curve (the rows of one kind, material, bath, thickness, start and
    level): rows, RMS residual in the rows' unit and in sigmas, the largest one."""
    groups: dict = {}
    for k, o in enumerate(problem.data.observations):
        groups.setdefault(o.curve, []).append(k)
    out = []
    for key, ks in groups.items():
        o = problem.data.observations[ks[0]]
        d = fit.residuals[ks] * problem.sigmas[ks]
        unit = {"ratio": "", "angle": "deg"}.get(o.kind, "s")
        out.append({"kind": o.kind, "material": o.material, "reference": o.reference, "bath_c": o.bath_c,
                    "thickness_mm": o.thickness_mm, "initial_c": o.initial_c, "level": o.level,
                    "lines": [problem.data.observations[k].line for k in ks], "rows": len(ks),
                    "rms": float(np.sqrt(np.mean(d ** 2))), "unit": unit,
                    "rms_sigma": float(np.sqrt(np.mean(fit.residuals[ks] ** 2))),
                    "worst_sigma": float(np.max(np.abs(fit.residuals[ks])))})
    return out


#: Row kinds whose value is a time read like the paper's words.
TIME_KINDS = ("time_to", "spread")


def row_reading(o, sigma: float) -> Reading | None:
    """A ``time_to`` / ``spread`` row's value and relation read as the paper's words are
    (:mod:`foldprint.model.paper_reading`), the row's sigma as the tolerance (0.5 s on the
    paper's rows, its reading of "~"); None for other rows."""
    if o.kind not in TIME_KINDS:
        return None
    return read(o.relation, o.value, sigma, "the row's sigma")


def _fmt(v: float, unit: str) -> str:
    return f"{v:.4g}{(' ' + unit) if unit and not unit.startswith('log') else ''}"


def findings(problem: Problem, fit: Fit, intervals: tuple[Interval, ...]) -> list[dict]:
    """What the data cannot say, as messages with the measurement that fixes each:
    parameters at a bound, parameters not identified, fewer rows than parameters, a rank
    deficient Jacobian, a model that misses the data beyond their uncertainty."""
    out = []
    n, k = len(fit.residuals), len(fit.x)
    if fit.dof <= 0:
        out.append({"code": "underdetermined", "message":
                    f"{n} measurement rows for {k} free parameters: the data can fix at most {n} combinations "
                    "of them, and no parameter is identified (" + NO_DOF_WHY + "); add curves (ratio rows) or "
                    "hold parameters (--fix)"})
    if fit.rank < k:
        out.append({"code": "rank", "message":
                    f"the data fix only {fit.rank} of {k} parameter combinations (rank of the Jacobian at the "
                    "optimum); the profile intervals show which parameters move freely"})
    if fit.dof > 0 and fit.scale > 1.0:
        from scipy.stats import chi2

        p = float(chi2.sf(fit.chi2, fit.dof))
        if p < 0.01:
            out.append({"code": "misfit", "message":
                        f"the model misses the data beyond their stated uncertainty (chi2 {fit.chi2:.1f} for "
                        f"{fit.dof} degrees of freedom, p = {p:.2g}); the intervals are widened by "
                        f"sqrt(chi2/dof) = {np.sqrt(fit.scale):.2f}"})
    ivs = {iv.label: iv for iv in intervals}
    lib_x, lo, hi = problem.library_point(), problem.lower, problem.upper
    for j, p in enumerate(problem.params):
        b, near = problem.config.bounds[p.name], NEAR_BOUND * (hi[j] - lo[j])
        edge = "lower" if lib_x[j] - lo[j] <= near else "upper" if hi[j] - lib_x[j] <= near else None
        if edge:
            out.append({"code": "start_at_bound", "parameter": p.label, "message":
                        f"the library the fit started from has {p.label} = {_fmt(lib_x[j], b.unit)}, "
                        f"{'on' if min(lib_x[j] - lo[j], hi[j] - lib_x[j]) <= AT_BOUND * (hi[j] - lo[j]) else 'next to'} "
                        f"its {edge} bound {_fmt(lo[j] if edge == 'lower' else hi[j], b.unit)} ({b.kind})"})
    for j, p in enumerate(problem.params):
        b, iv, at = problem.config.bounds[p.name], ivs.get(p.label), at_bound(problem, fit, j)
        if at:
            edge = b.lower if at == "lower" else b.upper
            why = ("a physical limit: the data push the model past physics" if b.kind == "physical"
                   else "a bound of our choosing, so the value is set by the box, not by the data")
            out.append({"code": "at_bound", "parameter": p.label, "message":
                        f"{p.label} = {_fmt(fit.x[j], b.unit)} is at its {at} bound {_fmt(edge, b.unit)} "
                        f"({why}; the bound: {b.source}). To fix it: {b.remedy}"})
        elif iv is not None and (iv.open_low or iv.open_high) and not iv.no_dof:
            side = ("on either side of" if iv.open_low and iv.open_high else
                    "below" if iv.open_low else "above")
            out.append({"code": "not_identified", "parameter": p.label, "message":
                        f"{p.label} is not identified {side} its value {_fmt(iv.value, b.unit)}: the fit stays "
                        f"within the {problem.config.confidence:.0%} threshold up to the bound. To fix it: {b.remedy}"})
    for o, r, sg, m in zip(problem.data.observations, fit.residuals, problem.sigmas, fit.predictions):
        rd = row_reading(o, sg)
        if o.relation != "about" and rd is not None:
            if rd.verdict(float(m)) == "misses":
                out.append({"code": "relation", "line": o.line, "message":
                            f"line {o.line}: the data say {o.kind} of {o.material} at {o.bath_c:g} C is "
                            f"{rd.phrase} ({rd.read_as}); the model, {m:.3g} s, misses that by "
                            f"{rd.off_by(float(m)):.2f} s"})
        elif abs(r) > MISS_SIGMA:
            unit = {"ratio": "", "angle": " deg"}.get(o.kind, " s")
            what = f"{o.kind} of {o.material}" + (f" - {o.reference}" if o.reference else "")
            out.append({"code": "miss", "line": o.line, "message":
                        f"line {o.line}: the model misses {what} at {o.bath_c:g} C: measured {o.value:g}{unit}, "
                        f"model {m:.3g}{unit}, {abs(r):.1f} sigma off (sigma {sg:g}{unit})"})
    return out
