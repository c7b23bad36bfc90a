"""Stiffnesses of the bar-and-hinge model from the materials' moduli
(``foldprint/data/mechanics.toml``, its sources there and in ``docs/mechanics.md``).

* A hinge material's storage modulus E(T): glassy and rubbery plateaus with a logistic
  transition in log10 E centred on its Tg (:func:`hinge_modulus`).
* A printed hinge strip of length L, thickness t and flat width w bent to uniform
  curvature rho / w carries the moment D L rho / w, D = E t^3 / (12 (1 - nu^2)): its
  rotational stiffness is :func:`hinge_stiffness`.
* Panel bending across a triangulation edge of length L: Filipov et al. 2017's
  k_B = C_B D (L / t)^(1/3) (:func:`bending_stiffness`).
* Panel stretching: a triangle of area A contributes E t A / L^2 to each of its edges'
  axial stiffness (:func:`bar_stiffness`): a lattice of equilateral triangles then has the
  in-plane modulus E t of the plate (Poisson ratio 1/3, the lattice's own).
Units: MPa = N/mm^2, mm, so stiffnesses are N/mm (bars) and N mm/rad (springs).
"""

from __future__ import annotations

import tomllib
from dataclasses import dataclass, field
from functools import lru_cache
from importlib import resources

import numpy as np

from ...core.errors import DesignError


@dataclass(frozen=True)
class ModulusCurve:
    """E(T) of one hinge material (MPa): plateaus and the transition width (C)."""

    glassy_mpa: float
    rubbery_mpa: float
    width_c: float
    poisson: float


@dataclass(frozen=True)
class MechanicsParams:
    """The contents of ``data/mechanics.toml``."""

    hinge: ModulusCurve
    panel_modulus_mpa: float
    panel_poisson: float
    bending_coefficient: float
    panel_strain_limit: float
    overrides: dict = field(default_factory=dict)  # material name -> ModulusCurve

    def curve(self, material: str) -> ModulusCurve:
        return self.overrides.get(material, self.hinge)


def _positive(table: dict, key: str, where: str) -> float:
    try:
        v = float(table[key])
    except (KeyError, TypeError, ValueError):
        raise DesignError(f"{where}: '{key}' must be a number; add it (see foldprint/data/mechanics.toml)") from None
    if not v > 0:
        raise DesignError(f"{where}: '{key}' must be > 0, got {v}")
    return v


def params_from(data: dict, source: str) -> MechanicsParams:
    """:class:`MechanicsParams` from a parsed mechanics TOML (``source`` names it in errors)."""
    try:
        hm, panel, check = data["hinge_modulus"], data["panel"], data["check"]
    except KeyError as exc:
        raise DesignError(f"{source}: missing table [{exc.args[0]}]") from None

    def curve(t: dict, base: ModulusCurve | None, where: str) -> ModulusCurve:
        get = (lambda k: _positive(t, k, where)) if base is None else (
            lambda k: _positive(t, k, where) if k in t else getattr(base, k))
        return ModulusCurve(get("glassy_mpa"), get("rubbery_mpa"), get("width_c"), get("poisson"))

    base = curve(hm, None, f"{source} [hinge_modulus]")
    over = {name: curve(t, base, f"{source} [materials.{name}]") for name, t in data.get("materials", {}).items()}
    return MechanicsParams(base, _positive(panel, "modulus_mpa", f"{source} [panel]"),
                           _positive(panel, "poisson", f"{source} [panel]"),
                           _positive(panel, "bending_coefficient", f"{source} [panel]"),
                           _positive(check, "panel_strain_limit", f"{source} [check]"), over)


@lru_cache(maxsize=1)
def default_params() -> MechanicsParams:
    """The shipped mechanics data."""
    text = (resources.files("foldprint") / "data" / "mechanics.toml").read_text(encoding="utf-8")
    return params_from(tomllib.loads(text), "foldprint/data/mechanics.toml")


def hinge_modulus(temp_c, tg_c: float, curve: ModulusCurve) -> np.ndarray:
    """Storage modulus (MPa) at ``temp_c`` of a material with glass transition ``tg_c``.

    >>> c = ModulusCurve(1500.0, 5.0, 5.0, 0.45)
    >>> round(float(hinge_modulus(40.0, 40.0, c)), 1)  # the geometric mean at Tg
    86.6
    """
    z = np.clip((np.asarray(temp_c, float) - tg_c) / curve.width_c, -50.0, 50.0)
    lg, lr = np.log10(curve.glassy_mpa), np.log10(curve.rubbery_mpa)
    return 10.0 ** (lr + (lg - lr) / (1.0 + np.exp(z)))


def plate_rigidity(modulus_mpa, thickness_mm, poisson: float):
    """D = E t^3 / (12 (1 - nu^2)) (N mm)."""
    return np.asarray(modulus_mpa, float) * np.asarray(thickness_mm, float) ** 3 / (12.0 * (1.0 - poisson**2))


def hinge_stiffness(modulus_mpa, length_mm, thickness_mm, width_mm, poisson: float):
    """Rotational stiffness (N mm/rad) of a hinge strip bent to uniform curvature:
    D L / w."""
    return plate_rigidity(modulus_mpa, thickness_mm, poisson) * np.asarray(length_mm) / np.asarray(width_mm)


def bending_stiffness(modulus_mpa, thickness_mm, edge_mm, poisson: float, coefficient: float):
    """Filipov et al. 2017's panel bending stiffness across an edge (N mm/rad)."""
    t = np.asarray(thickness_mm, float)
    return coefficient * plate_rigidity(modulus_mpa, t, poisson) * (np.asarray(edge_mm, float) / t) ** (1.0 / 3.0)


def bar_stiffness(modulus_mpa, thickness_mm, area_mm2, edge_mm):
    """Axial stiffness (N/mm) one triangle of ``area_mm2`` gives each of its edges."""
    return np.asarray(modulus_mpa) * np.asarray(thickness_mm) * np.asarray(area_mm2) / np.asarray(edge_mm) ** 2
