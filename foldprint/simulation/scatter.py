"""The scatter model: what is drawn for each Monte-Carlo sample of a printed part.

Five components (``foldprint/data/scatter.toml``, ``docs/robustness-model.md``), split by
what shares them (:class:`~foldprint.core.modes.ScatterScope`):

========== ======== ==================================================== =============
key        scope    quantity                                             spread
========== ======== ==================================================== =============
bath       shared   bath temperature of the run (C)                      sd_c
h_shared   shared   multiplier on h of the whole part (correlation error) sigma_ln
tg         hinge    shift of each hinge's Tg (C)                          sd_c
thickness  hinge    each hinge's thickness (mm)                           sd_mm
h_local    hinge    multiplier on each hinge's h (its place on the part)  sigma_ln
========== ======== ==================================================== =============

Sampling draws *standard* normals first (:func:`draw_normals`, truncated at
:data:`TRUNCATE_SD`) from one generator seeded by the caller, in a fixed order, and only
then scales them by the model (:func:`realise`). So the same seed gives the same
underlying draws whatever the spreads: a component switched off, or every spread scaled by
2, changes the values of the same samples (common random numbers), which is what makes
the one-at-a-time contributions and the sigma-scale sweep of
:mod:`foldprint.simulation.sensitivity` comparisons of like with like.
"""

from __future__ import annotations

import math
import tomllib
from dataclasses import dataclass, field, replace
from importlib import resources
from pathlib import Path
from typing import Iterable, Mapping

import numpy as np

from ..model.design import Design
from ..core.errors import DesignError
from ..core.inputs import read_toml, shown
from ..core.schema import MAX_TEXT, Where, number, string
from ..core.modes import ScatterScope, SpreadBasis

#: Normal draws are truncated to mean +/- this many standard deviations (a printed
#: hinge is never 5 sd off: the printer's QA would reject it).
TRUNCATE_SD = 3.0
#: The file layout this module reads.
SCHEMA = 2


@dataclass(frozen=True)
class Component:
    """One scattered quantity: its key, scope, TOML table and field, and what it is."""

    key: str
    scope: ScatterScope
    table: str  # under [shared.*] or [hinge.*]
    field: str  # the spread's key in that table
    attr: str  # the Scatter attribute
    label: str
    unit: str


COMPONENTS: tuple[Component, ...] = (
    Component("bath", ScatterScope.SHARED, "bath", "sd_c", "bath_sd_c", "bath temperature", "C"),
    Component("h_shared", ScatterScope.SHARED, "heat_transfer", "sigma_ln", "h_shared_sigma_ln",
              "heat transfer: correlation error", "ln"),
    Component("tg", ScatterScope.HINGE, "tg", "sd_c", "tg_sd_c", "Tg", "C"),
    Component("thickness", ScatterScope.HINGE, "thickness", "sd_mm", "thickness_sd_mm", "hinge thickness", "mm"),
    Component("h_local", ScatterScope.HINGE, "heat_transfer", "sigma_ln", "h_local_sigma_ln",
              "heat transfer: local", "ln"),
)
#: The largest spread a scatter file may give each component (its unit), and why: beyond
#: these the model is not describing a print but another process, and the samples leave the
#: recovery model's range (a Tg drawn 3 sd x MAX_SCALE away stays above 0 K from the
#: lowest Tg the schema accepts).
SPREAD_MAX = {"bath": (10.0, "ten times an open bath's +/- 1-2 C"),
              "h_shared": (1.0, "a factor e^3 = 20 at 3 sd, beyond any convection correlation's error"),
              "tg": (10.0, "ten times DMA repeatability, twice the 5.5 C between grades"),
              "thickness": (1.0, "more than the 0.8 mm hinge itself (samples are floored at 5 % of nominal)"),
              "h_local": (1.0, "a factor e^3 = 20 at 3 sd")}
#: The largest sigma scale of a sweep (--scales): 5x every spread at its maximum.
MAX_SCALE = 5.0
KEYS = tuple(c.key for c in COMPONENTS)
_BY_KEY = {c.key: c for c in COMPONENTS}
_BY_TABLE = {(c.scope.value, c.table): c for c in COMPONENTS}


def component(key: str) -> Component:
    """The component named ``key`` (one of :data:`KEYS`)."""
    try:
        return _BY_KEY[key]
    except KeyError:
        raise DesignError(f"unknown scatter component {key!r}; expected one of {', '.join(KEYS)}") from None


@dataclass(frozen=True)
class Scatter:
    """The spreads of the five components (units in :data:`COMPONENTS`), their sources and
    their bases (what each spread rests on: measured, a datasheet, the literature or our
    choice), by component key, not compared. Values come from the data file: build one
    with :func:`default_scatter`, :func:`load_scatter` or :meth:`zero`."""

    bath_sd_c: float
    h_shared_sigma_ln: float
    tg_sd_c: float
    thickness_sd_mm: float
    h_local_sigma_ln: float
    sources: Mapping[str, str] = field(default_factory=dict, compare=False)
    bases: Mapping[str, SpreadBasis] = field(default_factory=dict, compare=False)

    def __post_init__(self):
        for c in COMPONENTS:
            v = getattr(self, c.attr)
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) or v < 0:
                raise DesignError(f"scatter {c.key}: the spread must be a finite number >= 0, got {v!r}")

    @classmethod
    def zero(cls) -> "Scatter":
        """No scatter: every sample is the nominal part."""
        return cls(0.0, 0.0, 0.0, 0.0, 0.0)

    def spread(self, key: str) -> float:
        return float(getattr(self, component(key).attr))

    @property
    def is_zero(self) -> bool:
        """Every spread is zero: every sample is the nominal part (nothing to fold)."""
        return all(getattr(self, c.attr) == 0 for c in COMPONENTS)

    def basis(self, key: str) -> SpreadBasis | None:
        """What the spread of ``key`` rests on (None: not stated, a model built in code)."""
        return self.bases.get(component(key).key)

    def scaled(self, k: float) -> "Scatter":
        """Every spread times ``k`` (the sigma-scale sweep)."""
        if isinstance(k, bool) or not isinstance(k, (int, float)) or not (0 <= k <= MAX_SCALE):
            raise DesignError(f"scatter scale must be a number in [0, {MAX_SCALE:g}], got {k!r}")
        return replace(self, **{c.attr: getattr(self, c.attr) * k for c in COMPONENTS})

    def only(self, keys: Iterable[str]) -> "Scatter":
        """The components ``keys`` at their spreads, the others at zero."""
        keep = {component(k).key for k in keys}
        return replace(self, **{c.attr: getattr(self, c.attr) if c.key in keep else 0.0 for c in COMPONENTS})

    def without(self, key: str) -> "Scatter":
        """Every component but ``key``."""
        return replace(self, **{component(key).attr: 0.0})

    def to_json(self) -> dict:
        return {c.key: {"scope": c.scope.value, "label": c.label, "spread": getattr(self, c.attr),
                        "unit": c.unit, "source": self.sources.get(c.key, ""),
                        "basis": None if self.basis(c.key) is None else self.basis(c.key).value} for c in COMPONENTS}


def _old_layout(src: str, key: str) -> DesignError:
    where = {"tg": "[hinge.tg]", "thickness": "[hinge.thickness]", "bath": "[shared.bath]",
             "heat_transfer": "[shared.heat_transfer] (the correlation's error, one draw for the whole part) "
                              "or [hinge.heat_transfer] (the local variation, one draw per hinge)"}
    return DesignError(f"{src}: [{key}] is the schema-1 layout; the scatter model now splits shared and "
                       f"per-hinge quantities: write it as {where[key]} (see foldprint/data/scatter.toml)")


def scatter_from(data: Mapping, src: str, base: Scatter | None = None) -> Scatter:
    """The model a TOML table ``data`` (read from ``src``, named in errors) describes: with
    ``base`` (a user file), the fields it names replace base's; without (the shipped
    file), every spread, basis and source must be there."""
    if not isinstance(data, Mapping):
        raise DesignError(f"{src}: expected a TOML table")
    values = {} if base is None else {c.attr: getattr(base, c.attr) for c in COMPONENTS}
    sources = dict(base.sources) if base is not None else {}
    bases = dict(base.bases) if base is not None else {}
    groups = {s.value for s in ScatterScope}
    for key, group in data.items():
        if key == "schema":
            if group != SCHEMA:
                raise DesignError(f"{src}: schema: expected {SCHEMA}, got {group!r} (schema 1 drew h per hinge "
                                  "only; see foldprint/data/scatter.toml for the split layout)")
            continue
        if key in ("tg", "thickness", "bath", "heat_transfer"):
            raise _old_layout(src, key)
        if key not in groups:
            raise DesignError(f"{src}: unknown table [{key}]; expected [shared.*] or [hinge.*]")
        if not isinstance(group, Mapping):
            raise DesignError(f"{src}: {key}: expected tables like [{key}.<name>]")
        for name, table in group.items():
            comp = _BY_TABLE.get((key, name))
            if comp is None:
                names = sorted(t for s, t in _BY_TABLE if s == key)
                raise DesignError(f"{src}: unknown table [{key}.{name}]; expected one of "
                                  f"{', '.join(f'[{key}.{n}]' for n in names)}")
            if not isinstance(table, Mapping):
                raise DesignError(f"{src}: {key}.{name}: expected a table like [{key}.{name}]")
            _read_table(comp, table, src, f"{key}.{name}", values, sources, bases, user=base is not None)
    where = [f"{c.scope.value}.{c.table}" for c in COMPONENTS]
    missing = [f"{w}.{c.field}" for w, c in zip(where, COMPONENTS) if c.attr not in values]
    if base is None:  # the shipped model states what every spread rests on
        missing += [f"{w}.{k}" for w, c in zip(where, COMPONENTS) for k, got in (("basis", bases), ("source", sources))
                    if c.key not in got]
    if missing:
        raise DesignError(f"{src}: missing {', '.join(missing)}")
    return Scatter(**values, sources=sources, bases=bases)


def _read_table(comp: Component, table: Mapping, src: str, name: str, values: dict, sources: dict,
                bases: dict, user: bool) -> None:
    """One component's table into ``values``, ``sources`` and ``bases``. In a ``user``
    file a spread set without a basis counts as our choice (nothing says it was
    measured), and without a source gets one saying where it was set."""
    basis, where = None, f"{src}: {name}"
    for k, v in table.items():
        at = Where(src, f"{name}.{k}")
        if k == "source":
            sources[comp.key] = string(v, at, MAX_TEXT)
        elif k == "basis":
            try:
                basis = SpreadBasis(v) if isinstance(v, str) else None
            except ValueError:
                basis = None
            if basis is None:
                raise DesignError(f"{where}.basis: expected one of {', '.join(repr(b.value) for b in SpreadBasis)} "
                                  f"(what the spread rests on), got {v!r}")
            bases[comp.key] = basis
        elif k != comp.field:
            raise DesignError(f"{where}.{k}: unknown key; expected {comp.field}, basis or source")
        else:
            hi, why = SPREAD_MAX[comp.key]
            values[comp.attr] = number(v, at, unit=comp.unit)
            if not 0.0 <= values[comp.attr] <= hi:
                raise at.fail(f"must be in [0, {hi:g}] {comp.unit} ({why}), got {values[comp.attr]:g}")
    if user and comp.field in table and basis is None:
        bases[comp.key] = SpreadBasis.CHOICE
        if "source" not in table:
            sources[comp.key] = f"set in {src} without a basis or source"


def default_scatter() -> Scatter:
    """The shipped scatter model (``foldprint/data/scatter.toml``)."""
    text = (resources.files("foldprint") / "data" / "scatter.toml").read_text(encoding="utf-8")
    return scatter_from(tomllib.loads(text), "foldprint/data/scatter.toml", None)


def load_scatter(path: str | Path | None = None) -> Scatter:
    """The shipped model, with the fields a user TOML file names replaced."""
    base = default_scatter()
    if path is None:
        return base
    data = read_toml(path, "a scatter model (TOML: [shared.*] and [hinge.*] tables)")
    return scatter_from(data, shown(path), base)


@dataclass(frozen=True)
class Sample:
    """One drawn realisation: per hinge the Tg shift (C), thickness (mm) and h multiplier
    (the part's shared factor times the hinge's local one); the bath temperature (C);
    ``h_part``: the shared factor alone (for reports)."""

    tg_shift_c: np.ndarray
    thickness_mm: np.ndarray
    h_scale: np.ndarray
    bath_c: float
    h_part: float = 1.0


@dataclass(frozen=True)
class Normals:
    """Standard normal draws truncated at +/- :data:`TRUNCATE_SD`, one row per sample:
    ``hinge`` (n, 3, n_hinges): Tg, thickness, local h; ``shared`` (n, 2): bath, part h."""

    hinge: np.ndarray
    shared: np.ndarray


def draw_normals(n_hinges: int, n: int, seed: int) -> Normals:
    """The underlying draws of ``n`` samples from one generator seeded with ``seed``, in
    order (sample by sample: the hinges' Tg, thickness and local h, then the bath and the
    part's h), so the first k samples of n are the k samples of k."""
    return _normals(np.random.default_rng(seed), n_hinges, n)


def _normals(rng: np.random.Generator, n_hinges: int, n: int) -> Normals:
    """The next ``n`` samples' draws from ``rng`` (row-major from one stream, so blocks of
    rows give the very numbers of one draw)."""
    z = np.clip(rng.standard_normal((n, 3 * n_hinges + 2)), -TRUNCATE_SD, TRUNCATE_SD)
    return Normals(z[:, :3 * n_hinges].reshape(n, 3, n_hinges), z[:, 3 * n_hinges:])


def realise(design: Design, scatter: Scatter, normals: Normals) -> list[Sample]:
    """The samples the spreads of ``scatter`` make of ``normals``."""
    nominal_t = np.array([h.thickness for h in design.hinges], dtype=float)
    out = []
    for zh, zs in zip(normals.hinge, normals.shared):
        tg = zh[0] * scatter.tg_sd_c
        th = np.maximum(nominal_t + zh[1] * scatter.thickness_sd_mm, 0.05 * nominal_t)
        h_part = math.exp(float(zs[1]) * scatter.h_shared_sigma_ln)
        hs = h_part * np.exp(zh[2] * scatter.h_local_sigma_ln)
        bath = design.process.bath_temperature_c + float(zs[0]) * scatter.bath_sd_c
        out.append(Sample(tg, th, hs, bath, h_part))
    return out


def samples_between(design: Design, scatter: Scatter, seed: int, start: int, stop: int) -> list[Sample]:
    """Samples ``start`` .. ``stop - 1`` of the stream seeded with ``seed`` (the very ones
    :func:`iter_samples` yields there), realising only those: a chunk far into a stream
    does not realise every sample before it."""
    z = draw_normals(len(design.hinges), max(int(stop), 0), seed)
    return realise(design, scatter, Normals(z.hinge[start:stop], z.shared[start:stop]))


def iter_samples(design: Design, scatter: Scatter, n: int, seed: int, block: int = 1024):
    """The samples of :func:`draw_samples`, streamed: the generator fills ``block`` rows at a
    time, which gives the very numbers of one ``(n, k)`` draw (numpy fills row-major from
    one stream), so memory stays bounded whatever ``n`` is."""
    rng = np.random.default_rng(seed)
    nh = len(design.hinges)
    done = 0
    while done < n:
        m = min(block, n - done)
        yield from realise(design, scatter, _normals(rng, nh, m))
        done += m


def draw_samples(design: Design, scatter: Scatter, n: int, seed: int) -> list[Sample]:
    """``n`` samples of ``design`` under ``scatter`` from one generator seeded with
    ``seed`` (the boundary :mod:`foldprint.simulation.robust` calls)."""
    return realise(design, scatter, draw_normals(len(design.hinges), n, seed))
