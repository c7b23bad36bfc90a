"""Fitting the recovery model to hinge measurements (``foldprint calibrate``).

A :class:`Problem` holds the measurements (:mod:`foldprint.io.hinge_data`), the library the
fit starts from and which parameters are free (shared by every material, or one per
material); :meth:`Problem.residuals` compares the model with every row, in units of the
row's uncertainty; :func:`fit` minimises their sum of squares with
``scipy.optimize.least_squares`` inside the admissible ranges of ``data/calibration.toml``.
The uncertainty of each parameter (profile likelihood) and what the fit can and cannot say
are :mod:`foldprint.physics.calibration.profile`. Layout, example and reading:
``docs/calibrate.md``.

The model is the one every command uses (:func:`foldprint.physics.recovery.batch.material_batch_ratios`
on the recovery model's internal grid), so a fitted library gives the command line the
curves the fit saw. Observations:

* ``ratio``: R(t) interpolated on the grid;
* ``angle``: the angle between the panels, theta = 180 - rho_p (1 - f (1 - R)), rho_p =
  180 - ``printed_deg`` the printed fold, f the material's shape fixity (its ``fixity``
  rows, else the library's);
* ``time_to``: the first time R reaches ``level`` (the horizon when it does not);
* ``spread``: ``time_to`` of the material minus that of the reference.
"""

from __future__ import annotations

import tomllib
from dataclasses import dataclass, replace
from functools import lru_cache
from importlib import resources

import numpy as np

from ...core.constants import RECOVERY_HORIZON_S
from ...core import schema as sc
from ...core.errors import DataError
from ...io.hinge_data import HingeData, Observation
from ...model.materials import RECOVERY_BOUNDS, Material, MaterialLibrary, RecoveryParams
from ..recovery.batch import grid_until, material_batch_ratios

#: The recovery parameters a fit may move (the thermal properties k, rho, c and the branch
#: count are not fitted: textbook values and the paper's 16 branches).
FITTABLE = ("h_w_m2k", "c1", "c2", "log10_tau_ref_s", "spectrum_sigma_decades", "spectrum_span_decades")
KINDS = ("physical", "choice")


@dataclass(frozen=True)
class Bound:
    """The admissible range of one parameter, its kind, source, and the measurement that
    pins it (``data/calibration.toml``); ``hold``: the value calibrate holds it at unless
    told to fit it (None: fitted by default), ``hold_source`` where that value comes from."""

    name: str
    lower: float
    upper: float
    unit: str
    kind: str
    source: str
    remedy: str
    hold: float | None = None
    hold_source: str = ""


@dataclass(frozen=True)
class Settings:
    bounds: dict
    sigma: dict
    min_horizon_s: float
    confidence: float
    starts: int = 0


@lru_cache(maxsize=1)
def settings() -> Settings:
    """The shipped ``data/calibration.toml``."""
    res = resources.files("foldprint") / "data" / "calibration.toml"
    raw = tomllib.loads(res.read_text(encoding="utf-8"))
    bounds = {}
    for name in FITTABLE:
        b = raw["parameters"][name]
        if not b["lower"] < b["upper"] or b["kind"] not in KINDS:
            raise DataError(f"calibration.toml: parameters.{name}: needs lower < upper and kind in {KINDS}")
        hold = b.get("hold")
        if hold is not None and not (b["lower"] <= hold <= b["upper"] and b.get("hold_source")):
            raise DataError(f"calibration.toml: parameters.{name}: hold must lie within [lower, upper] and "
                            "have a hold_source")
        bounds[name] = Bound(name, float(b["lower"]), float(b["upper"]), b["unit"], b["kind"], b["source"],
                             b["remedy"], None if hold is None else float(hold), b.get("hold_source", ""))
    sig = raw["sigma"]
    return Settings(bounds, {"ratio": float(sig["ratio"]), "angle": float(sig["angle"]),
                             "time_to": float(sig["time_s"]), "spread": float(sig["time_s"])},
                    float(raw["fit"]["min_horizon_s"]), float(raw["fit"]["confidence"]), int(raw["fit"]["starts"]))


@dataclass(frozen=True)
class Hold:
    """A recovery parameter calibrate does not fit: its value (None: the library's) and
    where that value comes from."""

    name: str
    value: float | None
    source: str


def held_value(name: str, value) -> float:
    """A value ``--fix NAME=VALUE`` may hold ``name`` at (a number, or its text): a finite
    number a materials file may hold (:data:`~foldprint.model.materials.RECOVERY_BOUNDS`,
    so the fitted file loads back), else :class:`DataError` naming the range and why. Not
    limited to the fit's box (``data/calibration.toml``): holding c2 at a measured 30 K is
    a choice the user may make."""
    lo, hi, unit, why = RECOVERY_BOUNDS[name]
    rng = f"a finite number in [{lo:g}, {hi:g}]{' ' + unit if unit else ''} ({why})"
    at = sc.Where(f"--fix {name}", error=DataError)
    try:
        v = sc.number_text(value, at) if isinstance(value, str) else sc.number(value, at)
    except DataError:
        how = ", written in ASCII digits" if isinstance(value, str) else ""
        raise at.fail(f"must be {rng}{how}, got {sc.describe(value)}") from None
    if not lo <= v <= hi:
        raise at.fail(f"must be {rng}, got {v:g}")
    return v


def holds(fixed: dict | None = None, fit_names=(), config: Settings | None = None) -> tuple[Hold, ...]:
    """The parameters a calibration holds: those ``fixed`` ({name: value, or None for the
    library's}: ``--fix``), and those ``data/calibration.toml`` holds by default (its
    ``hold`` entries) unless named in ``fit_names`` (``--fit``)."""
    config = config or settings()
    fixed = dict(fixed or {})
    for name in list(fixed) + list(fit_names):
        if name not in FITTABLE:
            raise DataError(f"{name!r} is not a recovery parameter calibrate fits; use one of {', '.join(FITTABLE)}")
    both = [n for n in fit_names if n in fixed]
    if both:
        raise DataError(f"--fit {both[0]} and --fix {both[0]}: a parameter is either fitted or held; drop one")
    out = []
    for name in FITTABLE:
        b = config.bounds[name]
        if name in fixed:
            v = None if fixed[name] is None else held_value(name, fixed[name])
            out.append(Hold(name, v, "--fix" if v is not None else "--fix: the library's value"))
        elif b.hold is not None and name not in fit_names:
            out.append(Hold(name, b.hold, b.hold_source))
    return tuple(out)


@dataclass(frozen=True)
class Param:
    """One free coordinate of the fit: a recovery parameter, shared (``material`` None) or
    of one material."""

    name: str
    material: str | None = None

    @property
    def label(self) -> str:
        return self.name if self.material is None else f"{self.name}[{self.material}]"


def time_to(t: np.ndarray, r: np.ndarray, level: float, horizon: float) -> float:
    """First time R reaches ``level`` on (t, r), linear between grid points (as
    :meth:`foldprint.physics.recovery.curve.RecoveryCurve.time_to`); ``horizon`` if it never does."""
    k = int(np.argmax(r >= level))
    if r[k] < level:
        return horizon
    if k == 0:
        return float(t[0])
    return float(t[k - 1] + (level - r[k - 1]) / (r[k] - r[k - 1]) * (t[k] - t[k - 1]))


def _base_material(name: str, data: HingeData, library: MaterialLibrary) -> Material:
    """The material a fit starts from: the library's (its Tg replaced by measured ``tg``
    rows), or, for a new name, the library's first hinge material under that name."""
    tg = data.tg(name)
    if name in library:
        m = library[name]
        if m.role != "hinge" or m.recovery is None:
            raise DataError(f"{data.source}: material {name!r} is a {m.role} material of the library, not a "
                            "hinge material; rename the measured material")
        return m if tg is None else replace(m, tg_c=tg)
    if tg is None:
        rows = ", ".join(str(o.line) for o in data.observations if name in (o.material, o.reference))
        raise DataError(f"{data.source}: line {rows.split(', ')[0]}: material {name!r} is not in the library and "
                        "the file has no tg row for it; add its DMA tan-delta peak as a row "
                        f"'tg,{name},...,value=TG' (lines {rows} use it)")
    template = library.hinges()[0] if library.hinges() else None
    if template is None or template.recovery is None:
        raise DataError(f"{data.source}: the library has no hinge material to start {name!r} from")
    return replace(template, name=name, tg_c=tg, description="fitted by foldprint calibrate", source="",
                   fixity=None, fixity_source="", profile=None)


class Problem:
    """Measurements, the materials they name, and the free parameters.

    ``free``: the recovery parameters to fit (default every one of :data:`FITTABLE`);
    ``per_material``: those of ``free`` fitted once per material (the others are shared);
    ``fixed``: parameters held at a given value (the others not free keep the library's)."""

    def __init__(self, data: HingeData, library: MaterialLibrary, free=FITTABLE, per_material=(),
                 fixed: dict | None = None, config: Settings | None = None, measured: dict | None = None,
                 locked=()):
        self.data, self.library = data, library
        self.config = config or settings()
        fixed = dict(fixed or {})
        for name in list(free) + list(per_material) + list(fixed):
            if name not in FITTABLE:
                raise DataError(f"{name!r} is not a recovery parameter calibrate fits; use one of "
                                f"{', '.join(FITTABLE)}")
        fixed = {n: held_value(n, v) for n, v in fixed.items()}
        bad = [n for n in per_material if n not in free]
        if bad:
            raise DataError(f"--per-material {bad[0]}: {bad[0]} is held, not fitted; add --fit {bad[0]} "
                            "(or drop its --fix)")
        self.materials = data.materials()
        measured = dict(measured or {})
        #: per material, the parameters its DMA fixed (``measured``): neither held nor fitted here
        self.locked = {m: frozenset(locked) for m in self.materials if m in measured}
        base = {m: measured[m] if m in measured else _base_material(m, data, library) for m in self.materials}
        self.base = {m: replace(mat, recovery=replace(mat.recovery, **{k: v for k, v in fixed.items()
                                                                       if k not in self.locked.get(m, ())}))
                     for m, mat in base.items()}
        self.fixed = fixed
        self.params = tuple(p for name in free if name not in fixed
                            for p in ([Param(name, m) for m in self.materials if name not in self.locked.get(m, ())]
                                      if name in per_material else [Param(name)])
                            if not all(name in self.locked.get(m, ()) for m in self.materials))
        if not self.params:
            raise DataError("nothing to fit: every recovery parameter is fixed")
        self.fixity = {m: (data.fixity(m) if data.fixity(m) is not None else self.base[m].shape_fixity)
                       for m in self.materials}
        t_obs = [o.time_s for o in data.observations if o.time_s is not None] + \
            [o.value for o in data.observations if o.kind == "time_to"]
        self.horizon = float(min(RECOVERY_HORIZON_S, max(self.config.min_horizon_s, 2.0 * max(t_obs, default=0.0))))
        self.t = np.array(grid_until(self.horizon))
        self.curve_keys = sorted({(o.material, o.bath_c, o.thickness_mm, o.initial_c) for o in data.observations}
                                 | {(o.reference, o.bath_c, o.thickness_mm, o.initial_c) for o in data.observations
                                    if o.reference is not None}, key=str)
        self.sigmas = np.array([o.sigma if o.sigma is not None else self.config.sigma[o.kind]
                                for o in data.observations])
        self._plan()

    def _plan(self) -> None:
        """What every evaluation reads the same way, made once: the rows read off their curve
        at a time (ratio, angle) by curve, the angle rows' printed angles and fixities, the
        other rows, and the values and one-sided relations of :meth:`residuals_of`."""
        obs = self.data.observations
        by_key: dict = {}
        for i, o in enumerate(obs):
            if o.kind in ("ratio", "angle"):
                by_key.setdefault((o.material, o.bath_c, o.thickness_mm, o.initial_c), []).append(i)
        self._interp = {k: (np.array(ix), np.array([obs[i].time_s for i in ix], float)) for k, ix in by_key.items()}
        self._angle = np.array([i for i, o in enumerate(obs) if o.kind == "angle"], dtype=np.intp)
        self._printed = np.array([obs[i].printed_deg for i in self._angle], float)
        self._fix = np.array([self.fixity[obs[i].material] for i in self._angle], float)
        self._other = [i for i, o in enumerate(obs) if o.kind not in ("ratio", "angle")]
        self._values = np.array([o.value for o in obs])
        self._at_most = np.array([o.relation == "at_most" for o in obs], bool)
        self._at_least = np.array([o.relation == "at_least" for o in obs], bool)

    @property
    def lower(self) -> np.ndarray:
        return np.array([self.config.bounds[p.name].lower for p in self.params])

    @property
    def upper(self) -> np.ndarray:
        return np.array([self.config.bounds[p.name].upper for p in self.params])

    def library_point(self) -> np.ndarray:
        """The free parameters as the library the fit starts from has them."""
        def owner(p: Param) -> str:  # a shared parameter: the first material it applies to
            return p.material or next(m for m in self.materials if p.name not in self.locked.get(m, ()))
        return np.array([getattr(self.base[owner(p)].recovery, p.name) for p in self.params])

    def start(self) -> np.ndarray:
        """:meth:`library_point` moved inside the bounds (least_squares needs a strict start)."""
        x = self.library_point()
        span = self.upper - self.lower
        return np.clip(x, self.lower + 1e-3 * span, self.upper - 1e-3 * span)

    def recovery(self, x) -> dict[str, RecoveryParams]:
        """Each material's recovery parameters at the point ``x``."""
        out = {}
        for m in self.materials:
            vals = {p.name: float(v) for p, v in zip(self.params, x)
                    if p.material in (None, m) and p.name not in self.locked.get(m, ())}
            out[m] = replace(self.base[m].recovery, **vals)
        return out

    def curves(self, x) -> dict[tuple, np.ndarray]:
        """R on ``self.t`` for each (material, bath, thickness, initial) the rows use: one
        array pass per material and starting temperature."""
        rec = self.recovery(x)
        out = {}
        groups: dict[tuple, list] = {}
        for key in self.curve_keys:
            groups.setdefault((key[0], key[3]), []).append(key)
        for (m, init), keys in groups.items():
            mat = replace(self.base[m], recovery=rec[m])
            n = len(keys)
            ratio, _ = material_batch_ratios(mat, np.full(n, mat.tg_c), np.full(n, rec[m].h_w_m2k),
                                             np.array([k[2] for k in keys]), np.array([k[1] for k in keys]),
                                             init, self.t)
            out.update(zip(keys, ratio))
        return out

    def predict_row(self, o: Observation, curves: dict) -> float:
        """The model's value of one row, in the row's unit."""
        r = curves[(o.material, o.bath_c, o.thickness_mm, o.initial_c)]
        if o.kind == "ratio":
            return float(np.interp(o.time_s, self.t, r, left=0.0))
        if o.kind == "angle":
            rt = float(np.interp(o.time_s, self.t, r, left=0.0))
            return 180.0 - (180.0 - o.printed_deg) * (1.0 - self.fixity[o.material] * (1.0 - rt))
        t1 = time_to(self.t, r, o.level, self.horizon)
        if o.kind == "time_to":
            return t1
        ref = curves[(o.reference, o.bath_c, o.thickness_mm, o.initial_c)]
        return t1 - time_to(self.t, ref, o.level, self.horizon)

    def predict(self, x) -> np.ndarray:
        """:meth:`predict_row` of every row: the rows read off a curve at a time, a curve's
        at once (the same interpolation, element by element), the others one by one."""
        curves = self.curves(x)
        obs = self.data.observations
        out = np.empty(len(obs))
        for key, (ix, ts) in self._interp.items():
            out[ix] = np.interp(ts, self.t, curves[key], left=0.0)
        a = self._angle
        out[a] = 180.0 - (180.0 - self._printed) * (1.0 - self._fix * (1.0 - out[a]))
        for i in self._other:
            out[i] = self.predict_row(obs[i], curves)
        return out

    def residuals_of(self, pred: np.ndarray) -> np.ndarray:
        """(model - measured) / sigma per row; an ``at_most`` / ``at_least`` row counts only
        when the model is on its wrong side."""
        d = pred - self._values
        d = np.where(self._at_most, np.maximum(d, 0.0), d)
        d = np.where(self._at_least, np.minimum(d, 0.0), d)
        return d / self.sigmas

    def residuals(self, x) -> np.ndarray:
        return self.residuals_of(self.predict(x))


@dataclass(frozen=True)
class Fit:
    """The least-squares optimum: ``x`` (one value per :attr:`Problem.params`), chi2 = sum of
    squared residuals, ``dof`` rows minus free parameters, the Jacobian's rank (how many
    parameter combinations the data fix), and what ``least_squares`` said."""

    x: np.ndarray
    chi2: float
    dof: int
    rank: int
    residuals: np.ndarray
    predictions: np.ndarray
    nfev: int
    success: bool
    message: str
    #: chi2 at the end of each start of :func:`fit_best`, in the order of :func:`starts`
    #: (the library's first); () for a single start
    ends: tuple = ()

    @property
    def scale(self) -> float:
        """chi2 / dof when the model misses the data beyond their uncertainty (then the
        profile thresholds are widened by it, the Birge ratio squared), else 1."""
        return max(1.0, self.chi2 / self.dof) if self.dof > 0 else 1.0


def solve(problem: Problem, x0: np.ndarray, free: np.ndarray | None = None, max_nfev: int | None = None):
    """least_squares over the coordinates ``free`` (a boolean mask; default all) from ``x0``,
    the others held at x0. Returns (x, result)."""
    from scipy.optimize import least_squares

    free = np.ones(len(x0), bool) if free is None else free
    lo, hi = problem.lower[free], problem.upper[free]
    x = np.array(x0, float)

    def fun(y):
        x[free] = y
        return problem.residuals(x)

    y0 = np.clip(x0[free], lo + 1e-9 * (hi - lo), hi - 1e-9 * (hi - lo))
    res = least_squares(fun, y0, bounds=(lo, hi), x_scale=(hi - lo) / 10.0, diff_step=1e-4, method="trf",
                        max_nfev=max_nfev)
    x[free] = res.x
    return x.copy(), res


def fit(problem: Problem, x0: np.ndarray | None = None) -> Fit:
    """The least-squares fit from ``x0`` (default the library's values)."""
    x, res = solve(problem, problem.start() if x0 is None else np.asarray(x0, float))
    pred = problem.predict(x)
    r = problem.residuals_of(pred)
    s = np.linalg.svd(res.jac, compute_uv=False) if res.jac.size else np.zeros(0)
    rank = int(np.sum(s > 1e-6 * s.max())) if s.size and s.max() > 0 else 0
    return Fit(x, float(r @ r), len(r) - len(x), rank, r, pred, int(res.nfev), bool(res.success), str(res.message))


def starts(problem: Problem, n: int) -> list[np.ndarray]:
    """Where :func:`fit_best` starts: the library's point, then the first ``n`` points of
    an unscrambled Halton sequence (deterministic) over the middle 90 % of the box."""
    from scipy.stats import qmc

    out = [problem.start()]
    if n > 0:
        u = qmc.Halton(d=len(problem.params), scramble=False).random(n + 1)[1:]  # the first point is a corner
        out += list(problem.lower + (problem.upper - problem.lower) * (0.05 + 0.9 * u))
    return out


def fit_best(problem: Problem, n_starts: int | None = None) -> Fit:
    """The best least-squares fit of several starts (:func:`starts`; ``n_starts`` beside the
    library's point, default ``data/calibration.toml`` [fit] starts), so that the answer
    does not depend on the library the fit starts from; ties go to the earlier start."""
    n = problem.config.starts if n_starts is None else n_starts
    fits = [fit(problem, x0) for x0 in starts(problem, n)]
    best = min(range(len(fits)), key=lambda k: (fits[k].chi2, k))
    return replace(fits[best], nfev=sum(f.nfev for f in fits), ends=tuple(f.chi2 for f in fits))


def fitted_materials(problem: Problem, x) -> dict[str, Material]:
    """Each measured material with the fitted recovery parameters, its Tg and fixity (the
    measured ones where the file has rows)."""
    rec = problem.recovery(x)
    out = {}
    for m in problem.materials:
        mat = replace(problem.base[m], recovery=rec[m])
        fx = problem.data.fixity(m)
        if fx is not None:
            mat = replace(mat, fixity=fx, fixity_source=problem.data.property_source("fixity", m))
        out[m] = mat
    return out
