"""Fitting a material's viscoelastic model to its DMA (``storage``, ``loss``, ``tan_delta``
and ``relaxation`` rows of calibrate's CSV, :mod:`foldprint.io.hinge_data`).

The forward model is :class:`foldprint.physics.viscoelastic.Viscoelastic`: moduli, the
recovery model's WLF/Arrhenius shift and its Gaussian Prony spectrum. One material at a
time, the free parameters are

* ``tg_c``: the temperature of the model's tan-delta peak at 1 Hz (the paper's Tg, Methods),
  which is also the shift's reference temperature: for each point the spectrum's centre
  ``log10_tau_ref_s`` is the one that puts the peak there (:func:`peak_log10_tau`), so
  ``tg_c`` means what the paper and the recovery model both mean by it;
* ``log10_glassy_mpa``, ``log10_rubbery_mpa``: the moduli;
* ``c1``, ``c2`` (the shift) and ``spectrum_sigma_decades`` (the spectrum's width);
  ``spectrum_span_decades`` is held (``data/calibration.toml``) unless fitted.

Residuals are log ratios over the rows' relative sigmas. The fit, its starts and the
profile-likelihood intervals are :mod:`.fit` and :mod:`.profile`'s, on this problem.
"""

from __future__ import annotations

import math
import tomllib
from dataclasses import dataclass, replace
from functools import lru_cache
from importlib import resources

import numpy as np

from ...core.errors import DataError
from ...io.hinge_data import DYNAMIC_KINDS, DmaRow
from ...model.materials import Material, RecoveryParams
from ..viscoelastic import Viscoelastic
from .fit import Bound, Param, Settings, settings

#: The parameters a DMA fit may move, in the order of its points.
DMA_FITTABLE = ("tg_c", "log10_glassy_mpa", "log10_rubbery_mpa", "c1", "c2", "spectrum_sigma_decades",
                "spectrum_span_decades")
#: The shift and spectrum a DMA fixes: a material fitted to DMA keeps them in a recovery fit.
DMA_LOCKED = ("c1", "c2", "log10_tau_ref_s", "spectrum_sigma_decades", "spectrum_span_decades")
#: The frequency at which the tan-delta peak defines Tg (the paper's DMA, Methods).
TG_FREQUENCY_HZ = 1.0


@dataclass(frozen=True)
class DmaSettings:
    """``data/calibration.toml``'s [dma]: the default relative sigma, the margin of the
    ``tg_c`` box around the measured temperatures, and the moduli's bounds."""

    sigma: float
    tg_margin_c: float
    bounds: dict


@lru_cache(maxsize=1)
def dma_settings() -> DmaSettings:
    res = resources.files("foldprint") / "data" / "calibration.toml"
    raw = tomllib.loads(res.read_text(encoding="utf-8"))["dma"]
    bounds = {name: Bound(name, float(b["lower"]), float(b["upper"]), b["unit"], b["kind"], b["source"],
                          b["remedy"]) for name, b in raw["parameters"].items()}
    return DmaSettings(float(raw["sigma"]), float(raw["tg_margin_c"]), bounds)


@lru_cache(maxsize=4096)
def peak_log10_tau(sigma: float, span: float, n: int, ratio: float) -> float:
    """``log10_tau_ref_s`` that puts the model's tan-delta peak at 1 Hz at the reference
    temperature (where a_T = 1), for a spectrum of width ``sigma``, ``span`` decades, ``n``
    branches and E_r / E_g = ``ratio``. Tan delta depends on frequency and the times only
    through f tau, so with tau_ref = 1 s the peak sits at some f0 and tau_ref = f0 s moves it
    to 1 Hz: found on a grid of log f, then refined (bounded Brent)."""
    from scipy.optimize import minimize_scalar

    p = RecoveryParams(1.0, 1.0, 1.0, 1.0, 17.44, 51.6, 0.0, sigma, span, n)  # shift unused at a_T = 1
    ve = Viscoelastic(0.0, 1.0, ratio, p)
    grid = np.arange(-span / 2 - 6.0, span / 2 + 6.0, 0.05)
    k = int(np.argmax(ve.tan_delta(10.0 ** grid, 0.0)))
    res = minimize_scalar(lambda u: -float(ve.tan_delta(10.0 ** u, 0.0)), method="bounded",
                          bounds=(grid[max(k - 1, 0)], grid[min(k + 1, len(grid) - 1)]), options={"xatol": 1e-9})
    return float(res.x) + math.log10(TG_FREQUENCY_HZ)


def tan_delta_peak_c(ve: Viscoelastic, freq_hz: float = TG_FREQUENCY_HZ, window_c: float = 60.0) -> float:
    """The temperature of ``ve``'s tan-delta peak at ``freq_hz`` (deg C), searched within
    ``window_c`` of its reference temperature on a 0.1 C grid, then refined: the check that
    ``tg_c`` is what the paper calls Tg."""
    from scipy.optimize import minimize_scalar

    temps = ve.tg_c + np.arange(-window_c, window_c + 1e-9, 0.1)
    k = int(np.argmax(ve.tan_delta(freq_hz, temps)))
    lo, hi = temps[max(k - 1, 0)], temps[min(k + 1, len(temps) - 1)]
    res = minimize_scalar(lambda t: -float(ve.tan_delta(freq_hz, t)), method="bounded", bounds=(lo, hi),
                          options={"xatol": 1e-6})
    return float(res.x)


def data_tan_delta_peak(rows) -> float | None:
    """The temperature of the largest measured tan delta at 1 Hz (``tan_delta`` rows, or
    ``loss`` / ``storage`` pairs at one temperature), None without any: what the data say Tg is."""
    tan: dict[float, float] = {}
    pairs: dict[tuple, dict] = {}
    for r in rows:
        if r.frequency_hz is None or abs(r.frequency_hz - TG_FREQUENCY_HZ) > 1e-9:
            continue
        if r.kind == "tan_delta":
            tan[r.temperature_c] = r.value
        elif r.kind in ("storage", "loss"):
            pairs.setdefault(r.temperature_c, {})[r.kind] = r.value
    for t, d in pairs.items():
        if "storage" in d and "loss" in d and t not in tan:
            tan[t] = d["loss"] / d["storage"]
    return max(tan, key=tan.get) if tan else None


class DmaProblem:
    """One material's DMA rows and the free parameters of its viscoelastic model; the
    interface :func:`.fit.fit_best` and :func:`.profile.profile` use (``params``,
    ``lower``, ``upper``, ``start``, ``predict``, ``residuals_of``, ``residuals``, ``config``)."""

    def __init__(self, material: str, rows, template: Material, source: str, held: dict | None = None,
                 free_span: bool = False, config: Settings | None = None):
        if template.recovery is None:
            raise DataError(f"{source}: the library has no hinge material to start {material!r} from")
        self.material, self.rows, self.template, self.source = material, tuple(rows), template, source
        self.config = config or settings()
        self.dma = dma_settings()
        held = dict(held or {})
        temps = [r.temperature_c for r in self.rows]
        margin = self.dma.tg_margin_c
        self.tg_bound = Bound("tg_c", min(temps) - margin, max(temps) + margin, "deg C", "choice",
                              f"the measured temperatures +- {margin:g} C (data/calibration.toml [dma]): a tan-delta "
                              "peak farther outside the sweep is not seen by it",
                              "extend the temperature sweep past the tan-delta peak on both sides")
        bounds = {"tg_c": self.tg_bound, **self.dma.bounds,
                  **{n: self.config.bounds[n] for n in DMA_FITTABLE[3:]}}
        self.bounds = bounds
        self.held = {n: float(v) for n, v in held.items() if n in DMA_FITTABLE[3:]}
        span_hold = self.config.bounds["spectrum_span_decades"].hold
        if not free_span and "spectrum_span_decades" not in self.held:
            self.held["spectrum_span_decades"] = span_hold if span_hold is not None else \
                template.recovery.spectrum_span_decades
        self.params = tuple(Param(n, material) for n in DMA_FITTABLE if n not in self.held)
        self.sigmas = np.array([r.sigma if r.sigma is not None else self.dma.sigma for r in self.rows])
        self._values = np.array([r.value for r in self.rows])
        kinds = np.array([r.kind for r in self.rows])
        self._dyn = np.flatnonzero(np.isin(kinds, DYNAMIC_KINDS))
        self._rel = np.flatnonzero(kinds == "relaxation")
        self._kind = kinds
        self._t = np.array([r.temperature_c for r in self.rows])
        self._f = np.array([r.frequency_hz or 0.0 for r in self.rows])
        self._time = np.array([r.time_s or 0.0 for r in self.rows])

    @property
    def lower(self) -> np.ndarray:
        return np.array([self.bounds[p.name].lower for p in self.params])

    @property
    def upper(self) -> np.ndarray:
        return np.array([self.bounds[p.name].upper for p in self.params])

    def values(self, x) -> dict[str, float]:
        """Every parameter of :data:`DMA_FITTABLE` at the point ``x`` (held ones included)."""
        return {**self.held, **{p.name: float(v) for p, v in zip(self.params, x)}}

    def model(self, x) -> Viscoelastic:
        """The viscoelastic model at ``x``: its spectrum centred so that the 1 Hz tan-delta
        peak is at ``tg_c`` (:func:`peak_log10_tau`)."""
        v = self.values(x)
        eg, er = 10.0 ** v["log10_glassy_mpa"], 10.0 ** v["log10_rubbery_mpa"]
        rec = replace(self.template.recovery, c1=v["c1"], c2=v["c2"],
                      spectrum_sigma_decades=v["spectrum_sigma_decades"],
                      spectrum_span_decades=v["spectrum_span_decades"])
        tau = peak_log10_tau(rec.spectrum_sigma_decades, rec.spectrum_span_decades, rec.n_branches, er / eg)
        return Viscoelastic(v["tg_c"], eg, er, replace(rec, log10_tau_ref_s=tau))

    def start(self) -> np.ndarray:
        """A start from the data: Tg at the largest tan delta (else the largest loss, else the
        middle of the sweep), the moduli at the largest and smallest storage or relaxation
        modulus, the shift and width at the recovery model's holds and 1 decade."""
        rows = self.rows
        tg = data_tan_delta_peak(rows)
        if tg is None:
            loss = [r for r in rows if r.kind == "loss"]
            tg = max(loss, key=lambda r: r.value).temperature_c if loss else float(np.median(self._t))
        mod = [r.value for r in rows if r.kind in ("storage", "relaxation")]
        guess = {"tg_c": tg, "log10_glassy_mpa": math.log10(max(mod)) if mod else 3.0,
                 "log10_rubbery_mpa": math.log10(min(mod)) if mod else 0.5,
                 "c1": self.config.bounds["c1"].hold or 17.44, "c2": self.config.bounds["c2"].hold or 51.6,
                 "spectrum_sigma_decades": 1.0, "spectrum_span_decades": self.template.recovery.spectrum_span_decades}
        x = np.array([guess[p.name] for p in self.params])
        span = self.upper - self.lower
        return np.clip(x, self.lower + 0.05 * span, self.upper - 0.05 * span)

    def predict(self, x) -> np.ndarray:
        """The model's value of every row (MPa, or tan delta)."""
        ve = self.model(x)
        out = np.empty(len(self.rows))
        d = self._dyn
        if d.size:
            e1, e2 = ve.dynamic_mpa(self._f[d], self._t[d])
            k = self._kind[d]
            out[d] = np.where(k == "storage", e1, np.where(k == "loss", e2, e2 / e1))
        r = self._rel
        if r.size:
            out[r] = ve.relaxation_mpa(self._time[r], self._t[r])
        return out

    def residuals_of(self, pred: np.ndarray) -> np.ndarray:
        """ln(model / measured) / sigma per row (relative sigmas)."""
        return np.log(np.maximum(pred, 1e-300) / self._values) / self.sigmas

    def residuals(self, x) -> np.ndarray:
        return self.residuals_of(self.predict(x))


def dma_problems(data, library, held: dict | None = None, free_span: bool = False) -> list[DmaProblem]:
    """One :class:`DmaProblem` per material with DMA rows in ``data``, each started from the
    library's material of that name (a new name: the library's first hinge material)."""
    out = []
    for name in data.dma_materials():
        rows = [r for r in data.dma if r.material == name]
        if name in library:
            template = library[name]
            if template.role != "hinge" or template.recovery is None:
                raise DataError(f"{data.source}: line {rows[0].line}: material {name!r} is a {template.role} "
                                "material of the library, not a hinge material; rename the measured material")
        else:
            hinges = library.hinges()
            if not hinges:
                raise DataError(f"{data.source}: the library has no hinge material to start {name!r} from")
            template = hinges[0]
        out.append(DmaProblem(name, rows, template, data.source, held, free_span))
    return out


def fitted_material(problem: DmaProblem, x, library) -> Material:
    """The measured material with its DMA-fitted Tg, moduli, shift and spectrum (thermal
    properties and heat transfer: the library's, until recovery rows fit them)."""
    ve = problem.model(x)
    base = problem.template
    mat = replace(base, recovery=ve.params, tg_c=ve.tg_c, glassy_mpa=ve.glassy_mpa, rubbery_mpa=ve.rubbery_mpa)
    if problem.material not in library:
        mat = replace(mat, name=problem.material, description="fitted by foldprint calibrate", source="",
                      fixity=None, fixity_source="", profile=None)
    return mat


def rows_rms(problem: DmaProblem, residuals: np.ndarray) -> list[dict]:
    """Per DMA kind (and frequency): rows, RMS of ln(model/measured) and in sigmas."""
    groups: dict = {}
    for k, r in enumerate(problem.rows):
        groups.setdefault((r.kind, r.frequency_hz), []).append(k)
    out = []
    for (kind, f), ks in groups.items():
        z = residuals[ks]
        rel = z * problem.sigmas[ks]
        out.append({"kind": kind, "material": problem.material, "frequency_hz": f, "rows": len(ks),
                    "lines": [problem.rows[k].line for k in ks], "rms_log": float(np.sqrt(np.mean(rel ** 2))),
                    "rms_sigma": float(np.sqrt(np.mean(z ** 2))), "worst_sigma": float(np.max(np.abs(z)))})
    return out


@dataclass(frozen=True)
class DmaFit:
    """One material's DMA calibration: the problem, its optimum, the intervals (empty
    without the profile), the residuals per kind, findings, the fitted material, the
    temperature of the data's largest 1 Hz tan delta (None without one) and of the model's
    1 Hz tan-delta peak (found on the model, the check that it is ``tg_c``)."""

    problem: DmaProblem
    fit: object
    intervals: tuple
    curves: list
    findings: list
    material: Material
    data_peak_c: float | None
    model_peak_c: float


def dma_findings(problem: DmaProblem, fit, intervals) -> list[dict]:
    """Parameters at a bound or not identified (with the measurement that fixes each), and
    a model that misses the rows beyond their sigmas."""
    from scipy.stats import chi2

    from .profile import NO_DOF_WHY, at_bound

    out, m = [], problem.material
    if fit.dof <= 0:
        out.append({"code": "underdetermined", "material": m, "message":
                    f"{m}: {len(fit.residuals)} DMA rows for {len(fit.x)} free parameters: no parameter is "
                    f"identified ({NO_DOF_WHY}); add rows (a temperature sweep 2 C apart)"})
    elif fit.chi2 / fit.dof > 1.0 and chi2.sf(fit.chi2, fit.dof) < 0.01:
        out.append({"code": "misfit", "material": m, "message":
                    f"{m}: the viscoelastic model misses the DMA rows beyond their stated uncertainty (chi2 "
                    f"{fit.chi2:.1f} for {fit.dof} degrees of freedom); the intervals are widened by "
                    f"sqrt(chi2/dof) = {math.sqrt(fit.scale):.2f}"})
    ivs = {iv.label: iv for iv in intervals}
    for j, p in enumerate(problem.params):
        b, iv, at = problem.bounds[p.name], ivs.get(p.label), at_bound(problem, fit, j)
        if at:
            out.append({"code": "at_bound", "material": m, "parameter": p.label, "message":
                        f"{p.label} = {fit.x[j]:.4g} is at its {at} bound ({b.kind}: {b.source}). To fix it: "
                        f"{b.remedy}"})
        elif iv is not None and (iv.open_low or iv.open_high) and not iv.no_dof:
            out.append({"code": "not_identified", "material": m, "parameter": p.label, "message":
                        f"{p.label} is not identified ({iv.why}). To fix it: {b.remedy}"})
    return out


def fit_dma(problem: DmaProblem, library, with_profile: bool = True) -> DmaFit:
    """Fit ``problem`` (best of the configured starts), its profile intervals, findings,
    and the fitted material."""
    from .fit import fit_best
    from .profile import profile

    best = fit_best(problem)
    intervals = profile(problem, best, fine=True) if with_profile else ()
    ve = problem.model(best.x)
    return DmaFit(problem, best, intervals, rows_rms(problem, best.residuals), dma_findings(problem, best, intervals),
                  fitted_material(problem, best.x, library), data_tan_delta_peak(problem.rows), tan_delta_peak_c(ve))


def dma_json(d: DmaFit) -> dict:
    """What ``calibrate --json`` says of one material's DMA fit (docs/calibrate.md)."""
    pb, f = d.problem, d.fit
    ivs = {iv.label: iv for iv in d.intervals}
    params = []
    for p, v in zip(pb.params, f.x):
        b, iv = pb.bounds[p.name], ivs.get(p.label)
        params.append({"name": p.name, "value": float(v), "unit": b.unit, "low": iv.low if iv else None,
                       "high": iv.high if iv else None, "identified": iv.identified if iv else None,
                       "identified_why": iv.why if iv else None, "bounds": [b.lower, b.upper], "bound_kind": b.kind,
                       "bound_source": b.source})
    m = d.material
    return {"material": pb.material, "rows": len(pb.rows), "parameters": params,
            "held": {k: float(v) for k, v in pb.held.items()},
            "tg_c": m.tg_c, "reference_c": m.tg_c, "model_tan_delta_peak_c": d.model_peak_c,
            "data_tan_delta_peak_c": d.data_peak_c, "glassy_mpa": m.glassy_mpa, "rubbery_mpa": m.rubbery_mpa,
            "log10_tau_ref_s": m.recovery.log10_tau_ref_s,
            "fit": {"chi2": f.chi2, "dof": f.dof, "rank": f.rank, "scale": f.scale, "evaluations": f.nfev,
                    "start_ends": [float(c) for c in f.ends], "converged": f.success},
            "curves": d.curves, "findings": d.findings}
