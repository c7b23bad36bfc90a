"""The material library: digital SMP hinge materials H-1..H-7, the rigid panel
material and the rubbery base, with what the recovery model needs.

The shipped library is ``foldprint/data/materials.toml``; a user file given with
``--materials FILE`` (or :func:`load_library` ``extra=``) adds materials or
overrides fields of shipped ones.
"""

from __future__ import annotations

import tomllib
from dataclasses import dataclass, field, fields
from importlib import resources
from pathlib import Path
from typing import Iterable, Mapping

from ..core import schema as sc
from ..core.errors import MaterialError, where
from ..core.inputs import read_toml
from ..core.schema import TG_C
from . import composition, composition_library
from .composition import FractionProfile

ROLES = ("hinge", "panel", "base")


@dataclass(frozen=True)
class RecoveryParams:
    """Parameters of the hinge recovery model (see ``docs/recovery-model.md``).

    Thermal: conductivity ``k_w_mk`` (W/m/K), density ``rho_kg_m3``, heat capacity
    ``c_j_kgk`` (J/kg/K), bath-side heat-transfer coefficient ``h_w_m2k`` (W/m^2/K).
    Time-temperature superposition about the material's Tg: WLF constants ``c1``,
    ``c2`` (K) above Tg, Arrhenius below with the activation energy that makes
    log a_T and its slope continuous at Tg. Relaxation spectrum: ``n_branches``
    Prony terms, log-spaced over ``spectrum_span_decades`` about
    ``log10_tau_ref_s`` (relaxation time at Tg), with Gaussian weights of width
    ``spectrum_sigma_decades`` in log tau.
    """

    k_w_mk: float
    rho_kg_m3: float
    c_j_kgk: float
    h_w_m2k: float
    c1: float
    c2: float
    log10_tau_ref_s: float
    spectrum_sigma_decades: float
    spectrum_span_decades: float
    n_branches: int = 16

    def validate(self, at: sc.Where) -> None:
        """Every field a finite number within :data:`RECOVERY_BOUNDS` (``n_branches`` a
        whole number), or ``at.error`` naming the field, its range and the reason."""
        for f in fields(self):
            lo, hi, unit, why = RECOVERY_BOUNDS[f.name]
            v = getattr(self, f.name)
            if f.name == "n_branches":
                sc.integer(v, at / f.name, lo, hi)
                continue
            v = sc.number(v, at / f.name, unit=unit)
            if not lo <= v <= hi:
                raise (at / f.name).fail(f"must be in [{lo:g}, {hi:g}] {unit} ({why}), got {v:g}")


#: What a materials file may set, (lo, hi, unit, reason): physical ranges, wide enough for
#: any printable polymer, narrow enough that the recovery model stays in floating point
#: (checked at the corners: tests/test_option_files.py).
RECOVERY_BOUNDS = {
    "k_w_mk": (1e-3, 1e4, "W/m/K", "solids span aerogels, ~0.01, to diamond, ~2000"),
    "rho_kg_m3": (1.0, 3e4, "kg/m^3", "solids span aerogels to osmium, 22,600"),
    "c_j_kgk": (10.0, 2e4, "J/kg/K", "solids and liquids span ~100 to ~15,000"),
    "h_w_m2k": (0.1, 1e6, "W/m^2/K", "free convection in gas, ~5, to boiling water, ~1e5"),
    "c1": (0.1, 100.0, "", "WLF C1 of polymers is 5-40; the shift 10^C1 overflows past ~300"),
    "c2": (1.0, 1000.0, "K", "WLF C2 of polymers is 20-200 K"),
    "log10_tau_ref_s": (-12.0, 12.0, "", "relaxation times from picoseconds to 30,000 years"),
    "spectrum_sigma_decades": (0.01, 20.0, "decades", "a relaxation spectrum spans at most ~20 decades"),
    "spectrum_span_decades": (0.01, 30.0, "decades", "a relaxation spectrum spans at most ~20 decades"),
    "n_branches": (1, 256, "", "the paper's model has 16 branches; each costs a pass over the curve"),
}
#: Materials one file may define (the shipped library has 9; each hinge material is a
#: recovery curve per bath temperature in `foldprint materials`).
MAX_MATERIALS = 256


@dataclass(frozen=True)
class Material:
    """One printable material.

    ``tg_c`` is the glass transition (tan delta peak of DMA at 1 Hz, paper Methods).
    ``max_strain`` is the largest bending strain the material takes during programming
    (used by the design-rule checks). ``recovery`` is None for non-hinge materials.
    ``fixity`` is a measured shape fixity (None: :func:`default_fixity`, see
    :attr:`shape_fixity`), ``fixity_source`` where it comes from. ``glassy_mpa`` and
    ``rubbery_mpa``: the moduli a DMA gave (``foldprint calibrate``), None where none did.
    """

    name: str
    role: str
    tg_c: float
    color: str
    description: str = ""
    max_strain: float = 0.2
    recovery: RecoveryParams | None = None
    source: str = ""
    #: VeroWhite fraction profile of a continuous or graded material (``VW...`` names,
    #: synthesised by the library from :mod:`.composition`); None for library entries.
    profile: FractionProfile | None = None
    fixity: float | None = None
    fixity_source: str = ""
    #: A digital material jetted from VeroWhite and TangoBlack (the paper's grades, the
    #: ``VW...`` names): the composition model and the PolyJet resin count apply to it.
    #: False for a resin of its own (``calibrate`` writes ``blend = false`` for a material it
    #: adds: its data do not say what it is made of).
    blend: bool = True
    glassy_mpa: float | None = None
    rubbery_mpa: float | None = None

    @property
    def shape_fixity(self) -> float:
        """The share of a programmed bend the hinge keeps when released: the measured
        ``fixity``, else :func:`default_fixity`."""
        return default_fixity() if self.fixity is None else self.fixity

    @property
    def rgba(self) -> tuple[float, float, float, float]:
        """Display colour as floats in [0, 1]."""
        h = self.color.lstrip("#")
        vals = [int(h[i:i + 2], 16) / 255.0 for i in (0, 2, 4)]
        alpha = int(h[6:8], 16) / 255.0 if len(h) == 8 else 1.0
        return (vals[0], vals[1], vals[2], alpha)


def default_fixity() -> float:
    """Shape fixity of a digital SMP hinge that no measurement gives: E_g / (E_g + E_r).

    Programming bends the rubbery hinge (its network, modulus E_r, stores the bend), cooling
    under load freezes the bend into the glass (modulus E_g, stress-free in the programmed
    shape); on release the network pulls back until the two balance, keeping
    E_g / (E_g + E_r) of the bend (the two-phase picture of SMP fixity). E_g / E_r is the
    composition model's ``stiffness_ratio`` (``data/composition.toml``: 300, glassy
    VeroWhite-like resin 2-3 GPa against a rubbery digital SMP of a few MPa), so the default
    is 300/301 = 0.9967; the ratio's plausible range 100-1000 gives 0.990-0.999. The paper
    reports its protocol as "a shape fixity of 100%" (Mao 2015, Results): 0.997 is 0.3 deg
    off flat on a 90 deg hinge, below what a video reading resolves (docs/calibrate.md).

    >>> round(default_fixity(), 4)
    0.9967
    """
    r = composition.composition_model().stiffness_ratio
    return r / (r + 1.0)


@dataclass(frozen=True)
class MaterialLibrary:
    """An ordered, immutable collection of materials."""

    materials: tuple[Material, ...] = field(default_factory=tuple)

    def __post_init__(self) -> None:
        names = [m.name for m in self.materials]
        if len(set(names)) != len(names):
            raise MaterialError(f"duplicate material names in library: {names}")

    def __contains__(self, name: object) -> bool:
        if any(m.name == name for m in self.materials):
            return True
        if composition.is_composition_name(name):
            try:
                composition.parse_name(name)
            except MaterialError:
                return False
            return any(m.role == "hinge" and m.recovery is not None for m in self.materials)
        return False

    def __iter__(self):
        return iter(self.materials)

    def __len__(self) -> int:
        return len(self.materials)

    def get(self, name: str) -> Material:
        for m in self.materials:
            if m.name == name:
                return m
        if composition.is_composition_name(name):
            return composition_library.synthesise(self, name)
        raise MaterialError(
            f"unknown material {name!r}; known materials: {', '.join(self.names())}"
        )

    __getitem__ = get

    def names(self, role: str | None = None) -> list[str]:
        return [m.name for m in self.materials if role is None or m.role == role]

    def hinges(self) -> list[Material]:
        """Hinge materials, in library order (H-1..H-7 for the shipped one)."""
        return [m for m in self.materials if m.role == "hinge"]


_COLOR_CHARS = set("0123456789abcdefABCDEF")


def _parse_material(name: str, raw: Mapping, base_rec: Mapping, src: str,
                    previous: Material | None) -> Material:
    at = sc.Where(src, f"materials.{name}", error=MaterialError)
    sc.ident(name, at)
    sc.table(raw, at, {"role", "tg_c", "color", "description", "max_strain", "recovery", "source", "fixity",
                         "fixity_source", "blend", "glassy_mpa", "rubbery_mpa"})
    prev = previous
    role = raw.get("role", prev.role if prev else None)
    if role not in ROLES:
        raise (at / "role").fail(f"must be one of {ROLES}, got {sc.describe(role)}")
    tg = sc.number(raw.get("tg_c", prev.tg_c if prev else None), at / "tg_c", unit="deg C")
    if not TG_C[0] <= tg <= TG_C[1]:
        raise (at / "tg_c").fail(f"must be in [{TG_C[0]:g}, {TG_C[1]:g}] deg C (glass transitions of printable "
                                 f"polymers lie within it; the recovery law's Arrhenius shift divides by Tg in "
                                 f"kelvin), got {tg:g}")
    color = raw.get("color", prev.color if prev else "#808080")
    if not (isinstance(color, str) and color.startswith("#") and len(color) in (7, 9)
            and set(color[1:]) <= _COLOR_CHARS):
        raise (at / "color").fail(f"must be '#RRGGBB' or '#RRGGBBAA', got {sc.describe(color)}")
    max_strain = sc.number(raw.get("max_strain", prev.max_strain if prev else 0.2), at / "max_strain", 0.0, 10.0,
                           "(a fraction)", lo_open=True)
    fixity = raw.get("fixity", prev.fixity if prev else None)
    if fixity is not None:  # a measured shape fixity; None: the material's default (default_fixity)
        fixity = sc.number(fixity, at / "fixity", 0.0, 1.0, "(a fraction)", lo_open=True)
    blend = raw.get("blend", prev.blend if prev else True)
    if not isinstance(blend, bool):
        raise (at / "blend").fail(f"must be true (a VeroWhite/TangoBlack digital material) or false, "
                                  f"got {sc.describe(blend)}")
    moduli = [raw.get(k, getattr(prev, k) if prev else None) for k in ("glassy_mpa", "rubbery_mpa")]
    moduli = [None if v is None else sc.number(v, at / k, 0.0, 1e7, "MPa", lo_open=True)
              for k, v in zip(("glassy_mpa", "rubbery_mpa"), moduli)]
    if None not in moduli and not moduli[0] > moduli[1]:
        raise (at / "rubbery_mpa").fail(f"must be below glassy_mpa ({moduli[0]:g} MPa): a polymer softens "
                                        f"through its glass transition, got {moduli[1]:g}")
    rec = None
    if role == "hinge":
        merged = dict(base_rec)
        if prev is not None and prev.recovery is not None:
            merged.update({f.name: getattr(prev.recovery, f.name) for f in fields(prev.recovery)})
        merged.update(sc.table(raw.get("recovery", {}), at / "recovery"))
        allowed = {f.name for f in fields(RecoveryParams)}
        sc.table(merged, at / "recovery", allowed)
        missing = allowed - set(merged) - {"n_branches"}
        if missing:
            raise (at / "recovery").fail(f"missing {sorted(missing)}")
        rec = RecoveryParams(**merged)
        rec.validate(at / "recovery")
    text = {k: sc.string(raw.get(k, getattr(prev, k) if prev else ""), at / k, sc.MAX_TEXT)
            for k in ("description", "source", "fixity_source")}
    return Material(name=name, role=role, tg_c=tg, color=color, max_strain=max_strain, recovery=rec,
                    fixity=fixity, blend=blend, glassy_mpa=moduli[0], rubbery_mpa=moduli[1], **text)


def parse_library(data: Mapping, src: str, base: MaterialLibrary | None = None) -> MaterialLibrary:
    """Build a library from parsed TOML; entries override same-named ones in ``base``."""
    existing = {m.name: m for m in (base.materials if base else ())}
    top = sc.Where(src, error=MaterialError)
    base_rec = sc.table(data.get("recovery_defaults", {}), top / "recovery_defaults")
    if base is not None and not base_rec:
        first = next((m for m in base.materials if m.recovery is not None), None)
        if first is not None:
            base_rec = {f.name: getattr(first.recovery, f.name) for f in fields(first.recovery)}
    mats = data.get("materials")
    if not isinstance(mats, Mapping) or not mats:
        raise MaterialError(f"{where(src)}expected a [materials.NAME] table for each material")
    if len(mats) > MAX_MATERIALS:
        raise MaterialError(f"{where(src)}{len(mats)} materials; at most {MAX_MATERIALS} per file are accepted")
    order = list(existing)
    for name, raw in mats.items():
        existing[name] = _parse_material(name, raw, base_rec, src, existing.get(name))
        if name not in order:
            order.append(name)
    return MaterialLibrary(tuple(existing[n] for n in order))


def _read_toml(path: Path) -> dict:
    return read_toml(path, "a materials file (TOML, [materials.NAME] tables)", error=MaterialError)


_DEFAULT: MaterialLibrary | None = None


def default_library() -> MaterialLibrary:
    """The shipped library (cached; it is immutable)."""
    global _DEFAULT
    if _DEFAULT is None:
        res = resources.files("foldprint") / "data" / "materials.toml"
        data = tomllib.loads(res.read_text(encoding="utf-8"))
        _DEFAULT = parse_library(data, "foldprint/data/materials.toml")
    return _DEFAULT


def load_library(extra: str | Path | Iterable[str | Path] | None = None) -> MaterialLibrary:
    """The shipped library plus user files (later files override earlier ones)."""
    lib = default_library()
    if extra is None:
        return lib
    paths = [extra] if isinstance(extra, (str, Path)) else list(extra)
    for p in paths:
        p = Path(p)
        lib = parse_library(_read_toml(p), str(p), base=lib)
    return lib
