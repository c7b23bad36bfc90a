"""Stiffnesses of the bar-and-hinge model from the materials' moduli
(``foldprint/data/mechanics.toml``, its sources there and in ``docs/mechanics.md``).

* A hinge material's modulus: E(t_load, T), the relaxation modulus of its viscoelastic model
  (:mod:`foldprint.physics.viscoelastic`, the one that also gives its recovery) at the
  mechanics data's load time t_load (:func:`hinge_modulus`).
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
from dataclasses import dataclass, field, replace
from functools import lru_cache
from importlib import resources

import numpy as np

from ...core.errors import DesignError
from ..viscoelastic import Viscoelastic


@dataclass(frozen=True)
class HingeMechanics:
    """What the bar-and-hinge model adds to a hinge material's viscoelastic model: the load
    time (s) at which its relaxation modulus is read and the Poisson ratio."""

    load_time_s: float
    poisson: float


@dataclass(frozen=True)
class MechanicsParams:
    """The contents of ``data/mechanics.toml``."""

    hinge: HingeMechanics
    panel_modulus_mpa: float
    panel_poisson: float
    bending_coefficient: float
    panel_strain_limit: float
    overrides: dict = field(default_factory=dict)  # material name -> HingeMechanics

    def curve(self, material: str) -> HingeMechanics:
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
        hm, panel, check = data["hinge"], data["panel"], data["check"]
    except KeyError as exc:
        raise DesignError(f"{source}: missing table [{exc.args[0]}]") from None

    def curve(t: dict, base: HingeMechanics | None, where: str) -> HingeMechanics:
        moved = sorted({"glassy_mpa", "rubbery_mpa", "width_c"} & set(t))
        if moved:
            raise DesignError(f"{where}: {moved} are no longer mechanics data: a hinge's moduli are its "
                              f"material's (glassy_mpa, rubbery_mpa in a materials file, --materials), its "
                              f"E(T) the material's viscoelastic model; remove them")
        get = (lambda k: _positive(t, k, where)) if base is None else (
            lambda k: _positive(t, k, where) if k in t else getattr(base, k))
        return HingeMechanics(get("load_time_s"), get("poisson"))

    base = curve(hm, None, f"{source} [hinge]")
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


def hinge_modulus(model: Viscoelastic, temp_c, tg_c: float, hinge: HingeMechanics) -> np.ndarray:
    """Modulus (MPa) of a hinge of ``model`` with Tg ``tg_c`` (a scattered Tg moves the whole
    curve) at ``temp_c``: its relaxation modulus E(t_load, T) at the load time ``hinge.load_time_s``."""
    if float(tg_c) != model.tg_c:
        model = replace(model, tg_c=float(tg_c))
    return model.relaxation_mpa(hinge.load_time_s, temp_c)


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
