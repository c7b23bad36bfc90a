"""Jam probability under manufacturing and process scatter (Monte-Carlo).

Real hinges are not identical: Tg varies from hinge to hinge with the digital-material
mix, hinge thickness with the printer's tolerance, the heat-transfer coefficient with the
hinge's place in the bath, and the bath temperature from run to run. Each sample draws
all four from :class:`Scatter` (defaults and sources in ``foldprint/data/scatter.toml``,
``docs/robustness-model.md``), builds every hinge's recovery curve from the perturbed
values, and folds the printed geometry (arc hinges, the 3D swept check, every goal)
with :func:`foldprint.simulate.simulate`. A sample *jams* when it does not complete: a
collision, a goal unmet or out of order, or a hinge short of 98 %.

Samples are drawn up front from one seeded generator, in order, and evaluated in any
order on any number of processes: the same seed gives the same answer.
"""

from __future__ import annotations

import math
import tomllib
from dataclasses import dataclass, field, replace
from importlib import resources
from pathlib import Path
from typing import Callable, Mapping

import numpy as np

from . import guards
from .design import Design
from .errors import DesignError
from .kinematics import HingeDrive
from .materials import MaterialLibrary, default_library
from .modes import DEFAULT_HINGE_MODEL, HingeModel, Method, parse
from .recovery import recovery_curve
from .simulate import SimulationResult, simulate

#: z of a two-sided 95 % interval.
Z95 = 1.959963984540054
#: Normal draws are truncated to mean +/- this many standard deviations (a printed
#: hinge is never 5 sd off: the printer's QA would reject it).
TRUNCATE_SD = 3.0

_FIELDS = {"tg": {"sd_c"}, "thickness": {"sd_mm"}, "bath": {"sd_c"}, "heat_transfer": {"sigma_ln"}}


@dataclass(frozen=True)
class Scatter:
    """Standard deviations of the four scattered quantities (see module docstring)."""

    tg_sd_c: float = 1.0
    thickness_sd_mm: float = 0.04
    bath_sd_c: float = 1.0
    h_sigma_ln: float = 0.2
    sources: Mapping[str, str] = field(default_factory=dict, compare=False)

    def to_json(self) -> dict:
        return {"tg_sd_c": self.tg_sd_c, "thickness_sd_mm": self.thickness_sd_mm,
                "bath_sd_c": self.bath_sd_c, "heat_transfer_sigma_ln": self.h_sigma_ln}


def _scatter_from(data: Mapping, src: str, base: Scatter | None) -> Scatter:
    if not isinstance(data, Mapping):
        raise DesignError(f"{src}: expected a TOML table")
    values = {} if base is None else {"tg_sd_c": base.tg_sd_c, "thickness_sd_mm": base.thickness_sd_mm,
                                      "bath_sd_c": base.bath_sd_c, "h_sigma_ln": base.h_sigma_ln}
    sources = dict(base.sources) if base is not None else {}
    names = {("tg", "sd_c"): "tg_sd_c", ("thickness", "sd_mm"): "thickness_sd_mm",
             ("bath", "sd_c"): "bath_sd_c", ("heat_transfer", "sigma_ln"): "h_sigma_ln"}
    for key, table in data.items():
        if key == "schema":
            if table != 1:
                raise DesignError(f"{src}: schema: expected 1, got {table!r}")
            continue
        if key not in _FIELDS:
            raise DesignError(f"{src}: unknown table [{key}]; expected one of "
                              f"{', '.join(sorted(_FIELDS))}")
        if not isinstance(table, Mapping):
            raise DesignError(f"{src}: {key}: expected a table like [{key}]")
        for k, v in table.items():
            if k == "source":
                sources[key] = str(v)
                continue
            if k not in _FIELDS[key]:
                raise DesignError(f"{src}: {key}.{k}: unknown key; expected "
                                  f"{', '.join(sorted(_FIELDS[key]))} or source")
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) or v < 0:
                raise DesignError(f"{src}: {key}.{k}: must be a finite number >= 0, got {v!r}")
            values[names[(key, k)]] = float(v)
    missing = [n for n in names.values() if n not in values]
    if missing:
        raise DesignError(f"{src}: missing {', '.join(missing)}")
    return Scatter(**values, sources=sources)


def default_scatter() -> Scatter:
    """The shipped scatter model (``foldprint/data/scatter.toml``)."""
    text = (resources.files("foldprint") / "data" / "scatter.toml").read_text(encoding="utf-8")
    return _scatter_from(tomllib.loads(text), "foldprint/data/scatter.toml", None)


def load_scatter(path: str | Path | None = None) -> Scatter:
    """The shipped model, with the fields a user TOML file names replaced."""
    base = default_scatter()
    if path is None:
        return base
    p = Path(path)
    try:
        text = p.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise DesignError(f"{p}: scatter file not found") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise DesignError(f"{p}: cannot read the scatter file: {exc}") from None
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise DesignError(f"{p}: not valid TOML: {exc}") from None
    return _scatter_from(data, str(p), base)


@dataclass(frozen=True)
class Sample:
    """One drawn realisation: per hinge Tg shift (C), thickness (mm), h multiplier; the
    bath temperature (C)."""

    tg_shift_c: np.ndarray
    thickness_mm: np.ndarray
    h_scale: np.ndarray
    bath_c: float


def _truncnorm(rng: np.random.Generator, sd: float, size) -> np.ndarray:
    return np.clip(rng.standard_normal(size), -TRUNCATE_SD, TRUNCATE_SD) * sd


def draw_samples(design: Design, scatter: Scatter, n: int, seed: int) -> list[Sample]:
    """``n`` samples from one generator seeded with ``seed``, drawn in order."""
    rng = np.random.default_rng(seed)
    n_h = len(design.hinges)
    nominal_t = np.array([h.thickness for h in design.hinges])
    out = []
    for _ in range(n):
        tg = _truncnorm(rng, scatter.tg_sd_c, n_h)
        th = nominal_t + _truncnorm(rng, scatter.thickness_sd_mm, n_h)
        hs = np.exp(_truncnorm(rng, scatter.h_sigma_ln, n_h))
        bath = design.process.bath_temperature_c + float(_truncnorm(rng, scatter.bath_sd_c, 1)[0])
        out.append(Sample(tg, np.maximum(th, 0.05 * nominal_t), hs, bath))
    return out


def sample_drive(design: Design, library: MaterialLibrary, sample: Sample) -> HingeDrive:
    """The hinge drive of one sample: each hinge's curve from its perturbed material."""
    curves = []
    for k, h in enumerate(design.hinges):
        mat = library[h.material]
        rec = replace(mat.recovery, h_w_m2k=mat.recovery.h_w_m2k * float(sample.h_scale[k]))
        mat = replace(mat, tg_c=mat.tg_c + float(sample.tg_shift_c[k]), recovery=rec)
        curves.append(recovery_curve(mat, sample.bath_c, float(sample.thickness_mm[k]),
                                     design.process.fix_temperature_c))
    return HingeDrive(design, sample.bath_c, curves=curves)


@dataclass(frozen=True)
class Outcome:
    """What became of one sample."""

    jammed: bool
    reason: str | None  # "collision", "goal", "unfolded" or None
    pair: tuple[str, str] | None  # the first colliding panels
    time: float | None  # first contact (s)
    fold_time: float | None  # every hinge at 98 % (s), when it completed


def outcome_of(result: SimulationResult) -> Outcome:
    c = result.first_collision
    if result.completed:
        return Outcome(False, None, None, None, result.fold_time)
    if c is not None:
        return Outcome(True, "collision", tuple(sorted(c.panels)), float(c.time), None)
    if not all(g.met for g in result.goals):
        return Outcome(True, "goal", None, None, None)
    return Outcome(True, "unfolded", None, None, None)


def run_sample(args) -> Outcome:
    """Fold one sample (a module-level function, so processes and clusters can run it)."""
    design, library, sample, hinge_model, dt = args
    drive = sample_drive(design, library, sample)
    res = simulate(design, dt=dt, method=Method.FCL, hinge_model=hinge_model, drive=drive)
    return outcome_of(res)


def wilson(k: int, n: int, z: float = Z95) -> tuple[float, float]:
    """Wilson score interval of a binomial proportion k / n.

    >>> [round(x, 4) for x in wilson(0, 60)]
    [0.0, 0.0602]
    """
    if n <= 0:
        raise ValueError("n must be > 0")
    p = k / n
    den = 1.0 + z * z / n
    centre = (p + z * z / (2 * n)) / den
    half = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / den
    return max(0.0, centre - half), min(1.0, centre + half)


@dataclass(frozen=True)
class RobustResult:
    design: str
    samples: int
    seed: int
    hinge_model: HingeModel
    scatter: Scatter
    outcomes: tuple[Outcome, ...]
    nominal: SimulationResult

    @property
    def jams(self) -> int:
        return sum(o.jammed for o in self.outcomes)

    @property
    def jam_probability(self) -> float:
        return self.jams / self.samples

    @property
    def ci95(self) -> tuple[float, float]:
        return wilson(self.jams, self.samples)

    def collisions(self) -> list[tuple[tuple[str, str], int]]:
        """Colliding pairs, most frequent first (ties by name)."""
        counts: dict = {}
        for o in self.outcomes:
            if o.pair is not None:
                counts[o.pair] = counts.get(o.pair, 0) + 1
        return sorted(counts.items(), key=lambda kv: (-kv[1], kv[0]))

    def fold_time_percentiles(self) -> dict | None:
        """5th, 50th, 95th percentile of the fold time of the samples that completed."""
        ft = np.array([o.fold_time for o in self.outcomes if o.fold_time is not None])
        if ft.size == 0:
            return None
        p5, p50, p95 = np.percentile(ft, [5, 50, 95])
        return {"p5": float(p5), "p50": float(p50), "p95": float(p95)}


def jam_probability(design: Design, samples: int = 60, seed: int = 0, *, scatter: Scatter | None = None,
                    library: MaterialLibrary | None = None, hinge_model: HingeModel | str = DEFAULT_HINGE_MODEL,
                    dt: float = 0.01, nominal: SimulationResult | None = None, workers: int | None = None,
                    progress: Callable[[int, int], None] | None = None, mapper=None) -> RobustResult:
    """Monte-Carlo estimate of the probability that ``design`` jams.

    ``nominal``: the nominal simulation if the caller has it (else it is run here).
    ``mapper(fn, items, progress)``: how to run the samples (default: all local cores,
    :func:`foldprint.parallel.map_ordered`)."""
    if isinstance(samples, bool) or not isinstance(samples, int) or samples < 1:
        raise DesignError(f"samples must be a whole number >= 1, got {samples!r}")
    if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
        raise DesignError(f"seed must be a whole number >= 0, got {seed!r}")
    lib = library or default_library()
    scatter = scatter or default_scatter()
    model = parse(HingeModel, hinge_model, "hinge_model")
    guards.check_samples(design, samples, workers, dt)  # refuse before any fold (memory, time budget)
    if nominal is None:
        nominal = simulate(design, dt=dt, method=Method.FCL, hinge_model=model, library=lib)
    drawn = draw_samples(design, scatter, samples, seed)
    tasks = [(design, lib, s, model, dt) for s in drawn]
    if mapper is None:
        from .parallel import map_ordered

        outcomes = map_ordered(run_sample, tasks, workers=workers, progress=progress)
    else:
        outcomes = mapper(run_sample, tasks, progress)
    return RobustResult(design.name, samples, seed, model, scatter, tuple(outcomes), nominal)
