"""Where the shipped design templates live and what they are."""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

from ..core.errors import DesignError
from ..core.inputs import read_toml, shown

if TYPE_CHECKING:
    from ..core import schema as sc


def templates_dir() -> Path:
    """``$FOLDPRINT_TEMPLATES``, else the checkout's top-level ``templates/``."""
    env = os.environ.get("FOLDPRINT_TEMPLATES")
    if env:
        return Path(env)
    return Path(__file__).resolve().parents[2] / "templates"


def list_templates() -> list[dict]:
    """Name, path and description of every ``templates/*.toml``, sorted by name."""
    out = []
    d = templates_dir()
    if not d.is_dir():
        return out
    for p in sorted(d.glob("*.toml")):
        try:
            data = read_toml(p, "a TOML design (.toml)")
        except DesignError:  # listed without a description; loading it says what is wrong
            data = {}
        desc = data.get("description", "")
        out.append({"name": p.stem, "path": str(p), "description": desc if isinstance(desc, str) else ""})
    return out


def resolve_design_path(name_or_path: str) -> Path:
    """A path as given, or the template of that name."""
    p = Path(name_or_path)
    if p.suffix in (".toml", ".fold", ".svg") or "/" in name_or_path or os.path.lexists(p):
        return p
    cand = templates_dir() / f"{name_or_path}.toml"
    if os.path.lexists(cand):
        return cand
    names = [t["name"] for t in list_templates()]
    raise DesignError(f"{shown(name_or_path)}: no such file, and no template of that name; templates: {', '.join(names)}")


#: simulate's verdicts a template may claim: it completes, it collides (a first contact),
#: it stalls (no contact, but a hinge short of 98 % or a goal missed).
NOMINAL = ("completes", "collides", "stalls")


@dataclass(frozen=True)
class Claims:
    """What a template's description says the commands print: its ``[claims]`` table,
    each None where the description claims nothing. tests/test_template_claims.py runs
    the commands on every template and compares.

    ``nominal``: simulate's verdict (:data:`NOMINAL`); ``contact``, ``contact_s``: the
    first colliding panels and when (to 0.1 s); ``point_model``: the paper's point-hinge
    ROM's verdict; ``clearance_mm``: the nominal fold's smallest clearance (to 0.1 mm);
    ``marginal``: simulate calls it marginal (scatter closes that clearance);
    ``goals_met``; ``buildable``: the printed part can be built; ``unfolded``: the hinges
    short of 98 %; ``jams_under_scatter``: check's jam probability is above its warning
    threshold (FP180 or FP181)."""

    nominal: str | None = None
    contact: tuple[str, str] | None = None
    contact_s: float | None = None
    point_model: str | None = None
    clearance_mm: float | None = None
    marginal: bool | None = None
    goals_met: bool | None = None
    buildable: bool | None = None
    unfolded: tuple[str, ...] | None = None
    jams_under_scatter: bool | None = None


_CLAIM_KEYS = set(Claims.__dataclass_fields__)


def parse_claims(raw, at: sc.Where) -> Claims:
    """A ``[claims]`` table checked (keys, types, values); ``Claims()`` when absent."""
    from ..core import schema as sc  # here, not at the top: `foldprint templates` lists without it

    if raw is None:
        return Claims()
    raw = sc.table(raw, at, _CLAIM_KEYS)
    out = {}
    for key in ("nominal", "point_model"):
        if key in raw:
            out[key] = sc.string(raw[key], at / key)
            allowed = NOMINAL if key == "nominal" else NOMINAL[:2]
            if out[key] not in allowed:
                raise (at / key).fail(f"must be one of {', '.join(allowed)}, got {out[key]!r}")
    for key in ("marginal", "goals_met", "buildable", "jams_under_scatter"):
        if key in raw:
            out[key] = sc.boolean(raw[key], at / key)
    for key in ("contact_s", "clearance_mm"):
        if key in raw:
            out[key] = sc.number(raw[key], at / key, 0.0)
    if "contact" in raw:
        pair = tuple(sc.ident(v, at / "contact" / i) for i, v in enumerate(sc.array(raw["contact"], at / "contact", 2)))
        if len(pair) != 2:
            raise (at / "contact").fail("needs two panel ids")
        out["contact"] = pair
    if "unfolded" in raw:
        out["unfolded"] = tuple(sc.ident(v, at / "unfolded" / i)
                                for i, v in enumerate(sc.array(raw["unfolded"], at / "unfolded", sc.MAX_PANELS)))
    return Claims(**out)


def template_claims(name_or_path: str) -> Claims:
    """The ``[claims]`` of a template (or design file)."""
    from ..core import schema as sc

    p = resolve_design_path(name_or_path)
    data = read_toml(p, "a TOML design (.toml)")
    return parse_claims(data.get("claims"), sc.Where(shown(p)) / "claims")
