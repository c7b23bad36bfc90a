"""The composition model: a hinge material as a VeroWhite fraction.

The paper's hinge grades H-1..H-7 are digital materials, VeroWhite and TangoBlack jetted in
fixed (unpublished) ratios. This module gives the glass transition as a function of the
VeroWhite fraction ``w`` (``foldprint/data/composition.toml``: the law, its end members, the
interval the data support, the fraction we ASSUME for each grade, the fit residual; see
``docs/composition.md``), and names continuous and graded materials so that every part of
foldprint keyed by material name keeps working:

- ``"VW0.620"``: uniform VeroWhite fraction 0.620 (always three decimals);
- ``"VW0.600-0.900@width"``: graded, the fraction piecewise linear over evenly spaced knots
  (here two) across the hinge's width (``@width``, the arc direction, perpendicular to the
  fold line) or along its length (``@length``, along the fold line). A graded spec whose knots
  are all equal is the uniform name.

:class:`~foldprint.model.materials.MaterialLibrary` synthesises these names on demand
(:func:`~foldprint.model.composition_library.synthesise`): a hinge material whose ``tg_c`` is the law at the (mean) fraction,
whose recovery parameters are the grades' shared ones and whose ``profile`` is the
:class:`FractionProfile`. Only fractions inside :attr:`CompositionModel.fraction_range` exist.

This module must not import ``materials`` (that module imports this one).
"""

from __future__ import annotations

import math
import re
import tomllib
from dataclasses import dataclass
from enum import Enum
from functools import lru_cache
from importlib import resources
from typing import Any, Mapping, Sequence

import numpy as np

from ..core.errors import DesignError, MaterialError

#: Knots of a graded material: at most this many (a profile is a design intent, not a map).
MAX_KNOTS = 9
#: Decimals of a fraction in a canonical name (0.001 of fraction is ~0.08 C of Tg here).
DECIMALS = 3
_K = 273.15
_NUM = r"[01]\.\d{%d}" % DECIMALS
_NAME = re.compile(rf"^VW({_NUM}(?:-{_NUM})*)(?:@(width|length))?$")
_LOOSE = re.compile(r"^VW(\d*\.?\d+(?:-\d*\.?\d+)*)(?:@(width|length))?$")


class Along(Enum):
    """Direction a graded hinge's fraction varies in."""

    WIDTH = "width"    # across the hinge: the arc direction, perpendicular to the fold line
    LENGTH = "length"  # along the fold line


@dataclass(frozen=True)
class FractionProfile:
    """VeroWhite fraction as a piecewise-linear function of ``u`` in [0, 1].

    ``knots`` are the values at evenly spaced ``u`` (one knot = uniform, ``along`` None).
    For ``Along.WIDTH`` u runs across the hinge from the parent panel's side (0) to the child
    panel's side (1); for ``Along.LENGTH`` along the fold line from the hinge's first end to
    its second.
    """

    knots: tuple[float, ...]
    along: Along | None = None

    def __post_init__(self) -> None:
        if not self.knots:
            raise MaterialError("a fraction profile needs at least one knot")
        if (len(self.knots) == 1) != (self.along is None):
            raise MaterialError("a uniform profile has one knot and no direction; "
                                "a graded one has two or more knots and a direction")

    @property
    def uniform(self) -> bool:
        return len(self.knots) == 1

    def at(self, u) -> np.ndarray:
        """Fraction at ``u`` (array of values in [0, 1], clipped)."""
        u = np.clip(np.asarray(u, float), 0.0, 1.0)
        if self.uniform:
            return np.full(u.shape, self.knots[0])
        return np.interp(u, np.linspace(0.0, 1.0, len(self.knots)), self.knots)

    @property
    def mean(self) -> float:
        """Mean fraction over u (exact for the piecewise-linear profile)."""
        k = self.knots
        if len(k) == 1:
            return float(k[0])
        return float((sum(k) - 0.5 * (k[0] + k[-1])) / (len(k) - 1))

    @property
    def name(self) -> str:
        """The canonical material name of this profile."""
        body = "-".join(f"{v:.{DECIMALS}f}" for v in self.knots)
        return f"VW{body}" if self.uniform else f"VW{body}@{self.along.value}"


@dataclass(frozen=True)
class CompositionModel:
    """Tg(w) by Gordon-Taylor (``k``; Fox when ``law == "fox"``) between two end members."""

    law: str
    k: float
    tg_tango_c: float
    tg_vero_c: float
    tg_supported_c: tuple[float, float]
    assumed: tuple[tuple[str, float], ...]
    ramp: tuple[str, str]  # (TangoBlack, VeroWhite) display colours
    source: str = "foldprint/data/composition.toml"
    stiffness_ratio: float = 300.0  # E_glassy / E_rubbery for length-graded hinges
    strip_points: int = 8  # Gauss points per knot interval of a graded hinge

    @property
    def k_eff(self) -> float:
        """The Gordon-Taylor constant in use (Fox: Tg_V / Tg_T in kelvin)."""
        if self.law == "fox":
            return (self.tg_vero_c + _K) / (self.tg_tango_c + _K)
        return self.k

    # -- raw law, no range check (used by the fit and the checked API) -----------------
    def _tg(self, w):
        w = np.asarray(w, float)
        k = self.k_eff
        return (w * self.tg_vero_c + k * (1 - w) * self.tg_tango_c) / (w + k * (1 - w))

    def _w(self, tg):
        tg = np.asarray(tg, float)
        k = self.k_eff
        return k * (tg - self.tg_tango_c) / (self.tg_vero_c - tg + k * (tg - self.tg_tango_c))

    @property
    def fraction_range(self) -> tuple[float, float]:
        """The VeroWhite fractions the data support (those of the measured grades' Tg)."""
        lo, hi = self.tg_supported_c
        return (float(self._w(lo)), float(self._w(hi)))

    def check_fraction(self, fraction, what: str = "VeroWhite fraction") -> None:
        lo, hi = self.fraction_range
        f = np.asarray(fraction, float)
        bad = ~np.isfinite(f) | (f < lo - 1e-9) | (f > hi + 1e-9)
        if np.any(bad):
            v = f[bad].flat[0] if f.ndim else float(f)
            raise MaterialError(
                f"{what} {v:g} is outside the range the data support, "
                f"{lo:.4f}..{hi:.4f} (Tg {self.tg_supported_c[0]:g}..{self.tg_supported_c[1]:g} C, "
                f"H-1..H-7; docs/composition.md); choose a fraction inside it")

    def tg_c(self, fraction):
        """Tg (deg C) at VeroWhite fraction(s); refuses fractions outside the range."""
        self.check_fraction(fraction)
        out = self._tg(fraction)
        return float(out) if np.ndim(out) == 0 else out

    def fraction(self, tg_c):
        """VeroWhite fraction at Tg (deg C): the inverse of :meth:`tg_c`."""
        lo, hi = self.tg_supported_c
        t = np.asarray(tg_c, float)
        if np.any(~np.isfinite(t) | (t < lo - 1e-9) | (t > hi + 1e-9)):
            v = t.flat[0] if t.ndim else float(t)
            raise MaterialError(f"Tg {v:g} C is outside the range the data support, {lo:g}..{hi:g} C "
                                "(H-1..H-7; docs/composition.md)")
        out = self._w(t)
        return float(out) if np.ndim(out) == 0 else out

    def assumed_fraction(self, grade: str) -> float:
        """The fraction composition.toml assumes for a shipped grade (``"H-3"``)."""
        for name, w in self.assumed:
            if name == grade:
                return w
        raise MaterialError(f"no assumed VeroWhite fraction for {grade!r}; "
                            f"known: {', '.join(n for n, _ in self.assumed)}")

    def color(self, fraction: float) -> str:
        """Display colour on the TangoBlack (0) -> VeroWhite (1) ramp, ``#rrggbb``."""
        a, b = (np.array([int(c[i:i + 2], 16) for i in (1, 3, 5)], float) for c in self.ramp)
        w = min(1.0, max(0.0, float(fraction)))
        rgb = np.rint(a + (b - a) * w).astype(int)
        return "#" + "".join(f"{v:02x}" for v in rgb)


def _num(table: Mapping, key: str, src: str) -> float:
    v = table.get(key)
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
        raise MaterialError(f"{src}: {key} must be a finite number, got {v!r}")
    return float(v)


def parse_model(data: Mapping, src: str) -> CompositionModel:
    """Build the model from parsed TOML (the layout of data/composition.toml)."""
    law = data.get("law", {}).get("name", "gordon-taylor")
    if law not in ("gordon-taylor", "fox"):
        raise MaterialError(f"{src}: law.name must be 'gordon-taylor' or 'fox', got {law!r}")
    k = _num(data.get("law", {}), "k", f"{src}: law") if law == "gordon-taylor" else 1.0
    if k <= 0:
        raise MaterialError(f"{src}: law.k must be > 0 (else Tg(w) is not monotone), got {k}")
    em, sup = data.get("end_members", {}), data.get("supported", {})
    t_t, t_v = _num(em, "tangoblack_tg_c", f"{src}: end_members"), _num(em, "verowhite_tg_c", f"{src}: end_members")
    lo, hi = _num(sup, "tg_min_c", f"{src}: supported"), _num(sup, "tg_max_c", f"{src}: supported")
    if not (t_t < lo < hi <= t_v):
        raise MaterialError(f"{src}: need tangoblack_tg_c < tg_min_c < tg_max_c <= verowhite_tg_c, "
                            f"got {t_t}, {lo}, {hi}, {t_v}")
    grades = tuple((str(n), float(w)) for n, w in data.get("assumed_grades", {}).items() if n != "source")
    ramp = data.get("ramp", {})
    gr = data.get("grading", {})
    ratio = _num(gr, "stiffness_ratio", f"{src}: grading") if "stiffness_ratio" in gr else 300.0
    pts = gr.get("strip_points", 8)
    if ratio < 1 or not isinstance(pts, int) or isinstance(pts, bool) or not 1 <= pts <= 64:
        raise MaterialError(f"{src}: grading needs stiffness_ratio >= 1 and 1 <= strip_points <= 64, "
                            f"got {ratio}, {pts!r}")
    return CompositionModel(law=law, k=k, tg_tango_c=t_t, tg_vero_c=t_v, tg_supported_c=(lo, hi),
                            assumed=grades, ramp=(ramp.get("tangoblack", "#202020"),
                                                  ramp.get("verowhite", "#f0f0f0")), source=src,
                            stiffness_ratio=ratio, strip_points=pts)


def strips(profile: FractionProfile, points: int | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Quadrature of a profile over u: (u, weights summing to 1); Gauss-Legendre with
    ``points`` per knot interval (default the model's ``strip_points``); one strip if uniform."""
    if profile.uniform:
        return np.array([0.5]), np.array([1.0])
    g = points or composition_model().strip_points
    x, w = np.polynomial.legendre.leggauss(g)
    n = len(profile.knots) - 1
    u = np.concatenate([(i + 0.5 * (x + 1)) / n for i in range(n)])
    wt = np.concatenate([w / (2 * n)] * n)
    return u, wt


@lru_cache(maxsize=1)
def composition_model() -> CompositionModel:
    """The shipped composition model (cached; it is immutable)."""
    res = resources.files("foldprint") / "data" / "composition.toml"
    return parse_model(tomllib.loads(res.read_text(encoding="utf-8")), "foldprint/data/composition.toml")


# -- names ------------------------------------------------------------------------------

def is_composition_name(name: object) -> bool:
    """True if ``name`` is spelled like a continuous/graded material (``VW...``)."""
    return isinstance(name, str) and name.startswith("VW")


def _round(v: float) -> float:
    return round(float(v), DECIMALS)


def make_profile(fraction: float | Sequence[float], along: Along | str | None = None,
                 model: CompositionModel | None = None) -> FractionProfile:
    """A checked, rounded profile; equal knots collapse to uniform."""
    model = model or composition_model()
    if isinstance(fraction, (list, tuple, np.ndarray)):
        knots = tuple(_round(v) for v in fraction)
        if not 2 <= len(knots) <= MAX_KNOTS:
            raise MaterialError(f"a graded fraction needs 2..{MAX_KNOTS} values, got {len(knots)}")
        if along is None:
            raise MaterialError("a graded fraction needs along = 'width' or 'length'")
        try:
            along = Along(along) if not isinstance(along, Along) else along
        except ValueError:
            raise MaterialError(f"along must be 'width' or 'length', got {along!r}") from None
        if len(set(knots)) == 1:
            knots, along = knots[:1], None
    else:
        knots, along = (_round(fraction),), None
    model.check_fraction(np.array(knots))
    return FractionProfile(knots, along)


def vero(fraction: float | Sequence[float], along: Along | str | None = None) -> str:
    """Canonical material name of a VeroWhite fraction (or a graded list of them).

    ``fp.vero(0.62)`` -> ``"VW0.620"``; ``fp.vero([0.6, 0.9], "width")`` -> ``"VW0.600-0.900@width"``.
    """
    return make_profile(fraction, along).name


def parse_name(name: str, model: CompositionModel | None = None) -> FractionProfile:
    """The profile a canonical ``VW...`` name stands for (MaterialError if malformed/outside)."""
    m = _NAME.match(name) if isinstance(name, str) else None
    loose = _LOOSE.match(name) if isinstance(name, str) and m is None else None
    if loose is not None:
        try:
            vals = [float(v) for v in loose.group(1).split("-")]
            hint = make_profile(vals if len(vals) > 1 else vals[0], loose.group(2), model).name
        except (ValueError, MaterialError):
            hint = None
        if hint is not None:
            raise MaterialError(f"material {name!r}: the canonical spelling is {hint!r}")
    if m is None:
        raise MaterialError(
            f"material {name!r} is not a composition name; write 'VW0.620' (VeroWhite fraction, "
            f"{DECIMALS} decimals) or 'VW0.600-0.900@width' / '@length' (graded)")
    knots = tuple(float(v) for v in m.group(1).split("-"))
    along = m.group(2)
    if (len(knots) == 1) != (along is None):
        raise MaterialError(f"material {name!r}: one fraction takes no '@direction', several need one")
    prof = make_profile(knots if len(knots) > 1 else knots[0], along, model)
    if prof.name != name:
        raise MaterialError(f"material {name!r}: the canonical spelling is {prof.name!r}")
    return prof


def parse_material_spec(value: Any, where: str = "") -> str:
    """A hinge's ``material`` as written in TOML / FOLD metadata / the API -> material name.

    Accepts a name (``"H-3"``, ``"VW0.620"``), a number (a VeroWhite fraction), or a table
    ``{vero_fraction = 0.62}`` / ``{vero_fraction = [0.6, 0.9], along = "width"}``. Errors are
    :class:`DesignError` prefixed with ``where`` (e.g. ``"design.toml: hinges[2] (h3): material: "``).
    Names other than ``VW...`` are returned unchanged (the design checks them against the library).
    """
    try:
        if isinstance(value, str):
            if is_composition_name(value):
                parse_name(value)
            return value
        if isinstance(value, bool):
            raise MaterialError(f"expected a material name or a VeroWhite fraction, got {value!r}")
        if isinstance(value, (int, float)):
            return make_profile(float(value)).name
        if isinstance(value, Mapping):
            unknown = set(value) - {"vero_fraction", "along"}
            if unknown or "vero_fraction" not in value:
                raise MaterialError(f"a material table takes vero_fraction (a number, or a list for a "
                                    f"graded hinge) and along ('width' or 'length'); got keys {sorted(value)}")
            f = value["vero_fraction"]
            along = value.get("along")
            if isinstance(f, (list, tuple)):
                if not all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in f):
                    raise MaterialError(f"vero_fraction list must hold numbers, got {f!r}")
                return make_profile(list(f), along).name
            if isinstance(f, bool) or not isinstance(f, (int, float)):
                raise MaterialError(f"vero_fraction must be a number or a list of numbers, got {f!r}")
            if along is not None:
                raise MaterialError("along applies only to a graded vero_fraction (a list)")
            return make_profile(float(f)).name
        raise MaterialError(f"expected a material name or {{vero_fraction = ...}}, got {type(value).__name__}")
    except MaterialError as exc:
        raise DesignError(f"{where}{exc}") from None


def material_spec(name: str) -> Any:
    """Inverse of :func:`parse_material_spec` for writers: a name, or the fraction table."""
    if not is_composition_name(name):
        return name
    p = parse_name(name)
    if p.uniform:
        return {"vero_fraction": p.knots[0]}
    return {"vero_fraction": list(p.knots), "along": p.along.value}


def css_background(name: str, fallback: str = "#9a9a9a") -> str:
    """CSS background of a material's swatch on the ramp: its colour, or a left-to-right
    gradient through its knots for a graded material (``u`` = 0 on the left)."""
    model = composition_model()
    try:
        prof = parse_name(name)
    except MaterialError:
        return fallback
    if prof.uniform:
        return model.color(prof.knots[0])
    return "linear-gradient(to right, " + ", ".join(model.color(k) for k in prof.knots) + ")"


def ramp_legend(names) -> dict | None:
    """What a legend needs to explain the VeroWhite ramp, or None if no ``VW...`` name is used:
    the end colours, the supported range and each name's swatch background and label."""
    model = composition_model()
    used = sorted({n for n in names if is_composition_name(n)})
    if not used:
        return None
    labels = {}
    for n in used:
        p = parse_name(n)
        labels[n] = (f"VeroWhite {100 * p.knots[0]:.1f} % (Tg {model._tg(p.knots[0]):.1f} C)" if p.uniform else
                     f"VeroWhite {' -> '.join(f'{100 * k:.1f}' for k in p.knots)} % along the {p.along.value}"
                     f" (mean Tg {model._tg(p.mean):.1f} C)")
    return {"tangoblack": model.ramp[0], "verowhite": model.ramp[1],
            "range": list(model.fraction_range), "swatches": {n: css_background(n) for n in used},
            "labels": labels}
