"""Design-rule checks before printing. Each rule is a function ``(ctx) -> list[Finding]``,
so one run reports every problem.

Codes are stable (documented in ``docs/checks.md``); severities: error (the part will not
print or fold), warning (it may not), info (a margin worth knowing).
"""

from __future__ import annotations

import math
import tomllib
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path

import numpy as np

from ..model.design import Design, has_loops, tangent_factor
from ..core.constants import JAM_ERROR_ABOVE, JAM_WARN_ABOVE, tol
from ..core import schema as sc
from ..core.inputs import read_toml, shown
from ..model.materials import MaterialLibrary
from ..core.modes import HingeModel

SEVERITIES = ("error", "warning", "info")


@dataclass(frozen=True)
class Finding:
    code: str
    severity: str
    message: str
    hint: str = ""
    where: dict = field(default_factory=dict)  # panel / hinge / body ids
    point_mm: tuple[float, float, float] | None = None

    def to_json(self) -> dict:
        out = {"code": self.code, "severity": self.severity, "message": self.message,
               "where": dict(self.where), "hint": self.hint}
        if self.point_mm is not None:
            out["point_mm"] = [round(float(v), 3) for v in self.point_mm]
        return out


@dataclass(frozen=True)
class Printer:
    key: str
    name: str
    technology: str
    build_mm: tuple[float, float, float]
    layer_mm: float
    min_wall_mm: float
    min_gap_mm: float
    #: voxel pitch (x, y, z mm) for voxel print, and its source; None: not a voxel printer
    voxel_mm: tuple[float, float, float] | None = None
    voxel_source: str = ""


#: Printer profiles one file may hold (the shipped file has 6).
MAX_PRINTERS = 256
_PRINTER_KEYS = {"name", "technology", "build_mm", "layer_mm", "min_wall_mm", "min_gap_mm", "voxel_mm",
                 "voxel_source", "default", "voxel_default"}


def load_printers(extra: str | Path | None = None) -> dict[str, Printer]:
    """Shipped printer profiles plus a user TOML file of the same layout, each value
    through the boundary schema (lengths from 1 um to 10 m, names bounded)."""
    text = (resources.files("foldprint") / "data" / "printers.toml").read_text(encoding="utf-8")
    tables = [("foldprint/data/printers.toml", tomllib.loads(text))]
    if extra is not None:
        tables.append((shown(extra), read_toml(extra, "printer profiles (TOML, [printers.KEY] tables)")))
    out: dict[str, Printer] = {}
    for src, data in tables:
        top = sc.Where(src)
        profiles = sc.table(data.get("printers", {}), top / "printers")
        if len(profiles) > MAX_PRINTERS:
            raise (top / "printers").fail(f"{len(profiles)} profiles; at most {MAX_PRINTERS} are accepted")
        for key, raw in profiles.items():
            out[key] = _printer(key, sc.table(raw, top / f"printers.{key}", _PRINTER_KEYS), top / f"printers.{key}")
    return out


def _printer(key: str, raw, at: sc.Where) -> Printer:
    sc.ident(key, at)
    for need in ("build_mm", "min_wall_mm", "min_gap_mm"):
        if need not in raw:
            raise at.fail(f"needs build_mm = [x, y, z], min_wall_mm and min_gap_mm (missing {need})")

    def lengths(name):
        vals = sc.array(raw[name], at / name, 3, "three lengths [x, y, z] in mm")
        if len(vals) != 3:
            raise (at / name).fail(f"must be three lengths [x, y, z] in mm, got {len(vals)}")
        return tuple(sc.length(v, at / name / i) for i, v in enumerate(vals))

    return Printer(key, sc.string(raw.get("name", key), at / "name"), sc.string(raw.get("technology", ""),
                   at / "technology"), lengths("build_mm"), sc.length(raw.get("layer_mm", 0.1), at / "layer_mm"),
                   sc.length(raw["min_wall_mm"], at / "min_wall_mm"), sc.length(raw["min_gap_mm"], at / "min_gap_mm"),
                   lengths("voxel_mm") if "voxel_mm" in raw else None,
                   sc.string(raw.get("voxel_source", ""), at / "voxel_source", sc.MAX_TEXT))


def default_voxel_printer_key() -> str:
    """The shipped printer voxel print uses by default (``voxel_default = true``)."""
    text = (resources.files("foldprint") / "data" / "printers.toml").read_text(encoding="utf-8")
    data = tomllib.loads(text)["printers"]
    return next(k for k, v in data.items() if v.get("voxel_default"))


def default_printer_key() -> str:
    text = (resources.files("foldprint") / "data" / "printers.toml").read_text(encoding="utf-8")
    data = tomllib.loads(text)["printers"]
    return next(k for k, v in data.items() if v.get("default"))


@dataclass(frozen=True)
class Thresholds:
    """When the jam probability makes the pre-print check fail.

    ``error``: the check fails (exit 1) when the *lower* end of the 95 % interval is above
    this: the part jams more often than this even on the most favourable reading of the
    samples. ``warning``: a warning when the estimate itself is above this."""

    error: float = JAM_ERROR_ABOVE
    warning: float = JAM_WARN_ABOVE


@dataclass(frozen=True)
class CheckContext:
    """What the rules read. Every result is computed once, upstream, by
    :mod:`foldprint.apps.pipeline`; rules compute no simulation and no geometry.

    ``simulation``: the nominal :class:`~foldprint.simulation.simulate.SimulationResult` (or None
    when it could not run); ``assembly``: the printed part (None with
    ``assembly_error`` when it could not be built); ``printed_gaps``: panel pairs closer
    than the printer's minimum gap in the permanent state; ``clearance``: the smallest
    gap along the fold; ``robust``: the jam probability (or None when not run);
    ``sweep``: the same estimate with the scatter spreads scaled (points with ``.scale``
    and ``.result``, :func:`foldprint.simulation.sensitivity.sweep`; empty when not run)."""

    design: Design
    library: MaterialLibrary
    printer: Printer
    simulation: object | None = None
    assembly: object | None = None
    assembly_error: str | None = None
    printed_gaps: tuple = ()
    clearance: object | None = None
    robust: object | None = None
    thresholds: Thresholds = Thresholds()
    sweep: tuple = ()


def _f(code, sev, msg, hint="", point=None, **where):
    return Finding(code, sev, msg, hint, {k: v for k, v in where.items() if v is not None},
                   None if point is None else tuple(float(x) for x in point))


# -- rules ------------------------------------------------------------------------------

def rule_build_volume(ctx: CheckContext) -> list[Finding]:
    """The printed (permanent) part fits the printer, in some axis-aligned orientation."""
    if ctx.assembly is None or not ctx.assembly.bodies:
        return []
    pts = np.concatenate([b.vertices for b in ctx.assembly.bodies])
    size = pts.max(0) - pts.min(0)
    build = np.array(ctx.printer.build_mm)
    fits = np.all(np.sort(size) <= np.sort(build) + tol.length)
    if fits:
        return [_f("FP101", "info", f"part {size[0]:.1f} x {size[1]:.1f} x {size[2]:.1f} mm fits "
                   f"{ctx.printer.name} ({build[0]:g} x {build[1]:g} x {build[2]:g} mm)")]
    return [_f("FP100", "error", f"part {size[0]:.1f} x {size[1]:.1f} x {size[2]:.1f} mm does not fit the build "
               f"volume of {ctx.printer.name} ({build[0]:g} x {build[1]:g} x {build[2]:g} mm)",
               "scale the design down or choose a larger printer with --printer")]


def rule_buildable(ctx: CheckContext) -> list[Finding]:
    """The printed part could be built: its bodies are watertight and disjoint."""
    if ctx.assembly_error is None:
        return []
    return [_f("FP102", "error", f"the printed part cannot be built: {ctx.assembly_error}",
               "the panels or hinges overlap in the printed (permanent) state; change the target angles, "
               "lengths or holes")]


def rule_min_wall(ctx: CheckContext) -> list[Finding]:
    out = []
    w = ctx.printer.min_wall_mm
    for p in ctx.design.panels:
        if p.thickness < w:
            out.append(_f("FP110", "error", f"panel {p.id!r} is {p.thickness:g} mm thick, below the "
                          f"{w:g} mm minimum wall of {ctx.printer.name}",
                          f"make it at least {w:g} mm thick", panel=p.id))
    for h in ctx.design.hinges:
        thin = h.style.thin_mm if h.style.stepped else h.thickness
        if thin < w:
            out.append(_f("FP111", "warning" if thin >= 0.5 * w else "error",
                          f"hinge {h.id!r} is {thin:g} mm at its thinnest, below the {w:g} mm minimum wall",
                          "thicken the hinge (or its thin steps)", hinge=h.id))
    return out


def rule_min_gap(ctx: CheckContext) -> list[Finding]:
    """Gaps that would fuse: slots, holes, and the clearance between non-adjacent panels
    in the printed (permanent) state."""
    out = []
    g = ctx.printer.min_gap_mm
    for h in ctx.design.hinges:
        if h.style.max_segment_mm > 0 and h.length > h.style.max_segment_mm and h.style.slot_width_mm < g:
            out.append(_f("FP120", "error", f"hinge {h.id!r}: slots of {h.style.slot_width_mm:g} mm are narrower "
                          f"than the {g:g} mm minimum gap and will fuse", f"use slot_width_mm >= {g:g}", hinge=h.id))
    for p in ctx.design.panels:
        for k, hole in enumerate(p.holes):
            from shapely.geometry import Polygon

            poly = Polygon(hole)
            minx, miny, maxx, maxy = poly.bounds
            if min(maxx - minx, maxy - miny) < g:
                out.append(_f("FP121", "error", f"panel {p.id!r} holes[{k}] is narrower than the {g:g} mm minimum gap",
                              "widen the hole", panel=p.id))
    for gap in ctx.printed_gaps:
        if gap.distance >= g:
            continue
        a, b = gap.panels
        msg = (f"panels {a!r} and {b!r} are {gap.distance:.2f} mm apart in the printed state, below the "
               f"{g:g} mm minimum gap: they would print fused" if gap.distance > 0 else
               f"panels {a!r} and {b!r} intersect in the printed (permanent) state")
        out.append(_f("FP122", "error", msg, "move the panels apart or change the target angles",
                      gap.point, panels=[a, b]))
    return out


def rule_hinge_strain(ctx: CheckContext) -> list[Finding]:
    """Strain when a hinge is programmed flat: bending, eps = t / (2 r) at its outer fibres
    (r = R for a tree's arc hinge). A hinge of a pattern with loops turns about its fold
    line, so it is printed as the arc tangent to both panels: radius r = R f and length
    w f with f = (rho/2)/tan(rho/2) (``docs/loops.md``); flattening also stretches it by
    1/f - 1, added to the bending strain."""
    out = []
    centred = has_loops(ctx.design)
    for h in ctx.design.hinges:
        mat = ctx.library[h.material]
        f = float(tangent_factor(h.angle)) if centred else 1.0
        r = h.radius * f
        bend, stretch = h.thickness / (2 * r), 1.0 / f - 1.0
        eps = bend + stretch
        how = (f"t = {h.thickness:g} mm, R = {h.radius:g} mm" if not centred else
               f"bending {bend:.0%} at the printed radius {r:.2f} mm + stretching {stretch:.0%}: "
               f"a loop hinge is printed {1 - f:.0%} shorter than flat")
        fix = (f"increase the radius to at least {h.thickness / (2 * mat.max_strain):.2f} mm" if not centred else
               "use a smaller fold angle (the stretch depends on the angle alone) or a larger radius")
        if eps > mat.max_strain:
            out.append(_f("FP130", "error", f"hinge {h.id!r}: programming strain {eps:.0%} exceeds {mat.name}'s "
                          f"limit {mat.max_strain:.0%} ({how})", fix, hinge=h.id))
        elif eps > 0.8 * mat.max_strain:
            out.append(_f("FP131", "warning", f"hinge {h.id!r}: programming strain {eps:.0%} is within 20 % of "
                          f"{mat.name}'s limit {mat.max_strain:.0%} ({how})",
                          "increase the bend radius" if not centred else fix, hinge=h.id))
        if 2 * h.radius <= h.thickness and abs(h.angle) > math.radians(150):
            out.append(_f("FP132", "error", f"hinge {h.id!r}: radius {h.radius:g} mm is too tight for a "
                          f"{math.degrees(abs(h.angle)):.0f} deg fold of {h.thickness:g} mm: its faces would meet",
                          "increase the radius", hinge=h.id))
    return out


def rule_hinge_fits(ctx: CheckContext) -> list[Finding]:
    """The flat hinge strip (w/2 each side of the fold line) must fit in both panels, and a
    hinge should be longer than its width."""
    from shapely.geometry import LineString

    out = []
    d = ctx.design
    for h in d.hinges:
        w = h.width
        band = LineString(h.line).buffer(w / 2, cap_style="flat")
        for pid in h.panels:
            poly = d.panel(pid).polygon
            rest = poly.difference(band)
            if rest.is_empty or rest.area < 0.05 * poly.area:
                out.append(_f("FP140", "error", f"hinge {h.id!r}: its flat width {w:.2f} mm (R {h.radius:g} mm x "
                              f"{math.degrees(abs(h.angle)):.0f} deg) leaves almost nothing of panel {pid!r}",
                              "reduce the bend radius or enlarge the panel", hinge=h.id, panel=pid))
        if h.length < 0.5 * w:
            out.append(_f("FP141", "warning", f"hinge {h.id!r} is {h.length:.1f} mm long but {w:.1f} mm wide: "
                          "short hinges twist", "lengthen the fold line or reduce the radius", hinge=h.id))
    return out


def rule_temperatures(ctx: CheckContext) -> list[Finding]:
    out = []
    pr = ctx.design.process
    for h in ctx.design.hinges:
        tg = ctx.library[h.material].tg_c
        if pr.program_temperature_c <= tg:
            out.append(_f("FP150", "error", f"hinge {h.id!r} ({h.material}, Tg {tg:g} C): programming at "
                          f"{pr.program_temperature_c:g} C is not above Tg, so it cannot be programmed flat",
                          f"program above {tg + 15:g} C", hinge=h.id))
        if pr.bath_temperature_c <= tg:
            out.append(_f("FP151", "error", f"hinge {h.id!r} ({h.material}, Tg {tg:g} C): a {pr.bath_temperature_c:g} C "
                          "bath is below Tg, so it never folds", f"use a bath above {tg + 15:g} C", hinge=h.id))
        if pr.fix_temperature_c >= tg:
            out.append(_f("FP152", "error", f"hinge {h.id!r} ({h.material}, Tg {tg:g} C): fixing at "
                          f"{pr.fix_temperature_c:g} C is not below Tg, so the flat shape will not hold",
                          "cool below Tg before releasing", hinge=h.id))
    return out


def rule_fold_within_duration(ctx: CheckContext) -> list[Finding]:
    """Every hinge reaches 98 % within the process (the simulation's recovery curves)."""
    out = []
    d = ctx.design
    if ctx.simulation is None:
        return out
    for h, ft in zip(d.hinges, ctx.simulation.trajectory.fold_times):
        if d.process.bath_temperature_c <= ctx.library[h.material].tg_c:
            continue  # reported by FP151
        if ft is None or ft > d.process.duration_s:
            out.append(_f("FP160", "error", f"hinge {h.id!r} ({h.material}) does not reach 98 % within the "
                          f"{d.process.duration_s:g} s process" + ("" if ft is None else f" (needs {ft:.1f} s)"),
                          "lengthen duration_s or raise the bath temperature", hinge=h.id))
    return out


def rule_folding(ctx: CheckContext) -> list[Finding]:
    """The nominal fold of the printed geometry: collisions, goals, and the smallest
    clearance as a margin."""
    res = ctx.simulation
    if res is None:
        return []
    model = res.trajectory.model
    out = []
    c = res.first_collision
    crossing = {tuple(sorted(g.panels)) for g in ctx.printed_gaps if g.distance <= 0.0}
    if c is not None:
        # panels that already cross in the printed state (FP122) collide whatever the order:
        # a lower-Tg hint would send the designer on a search that cannot succeed (issue 18)
        hint = ("these panels cross in the printed (permanent) state (FP122): no hinge order or material "
                "avoids it; change the target angles, lengths or holes" if crossing else
                "give the hinges that must fold first lower-Tg materials, so these panels fold in sequence")
        out.append(_f("FP170", "error", f"panels {c.panels[0]!r} and {c.panels[1]!r} collide at {c.time:.3f} s "
                      f"while folding ({model} hinges, 3D swept check)", hint,
                      c.point if all(map(math.isfinite, c.point)) else None, panels=list(c.panels)))
    for g in res.goals:
        if not g.met:
            why = "never passes" if g.time is None else "passes out of order"
            out.append(_f("FP171", "error", f"goal {g.goal.id!r}: panel {g.goal.panel!r} {why} through "
                          f"holes[{g.goal.hole}] of {g.goal.target!r} (holes count from 0)",
                          "adjust the hinge sequence", goal=g.goal.id))
    gap = ctx.clearance
    if c is None and gap is not None:
        out.append(_f("FP172", "info", f"smallest clearance between non-adjacent panels while folding: "
                      f"{gap.distance:.2f} mm ({gap.panels[0]!r}-{gap.panels[1]!r} at {gap.time:.2f} s, "
                      f"{model} hinges)", "", panels=list(gap.panels)))
    return out


def jam_verdict(r, th: Thresholds) -> str:
    """The severity a jam-probability estimate earns: error when the interval's lower end
    is above ``th.error``, warning when the estimate is above ``th.warning``, else info."""
    if r.ci95[0] > th.error:
        return "error"
    return "warning" if r.jam_probability > th.warning else "info"


def _pct(r) -> str:
    lo, hi = r.ci95
    return f"{r.jam_probability:.0%} ({lo:.0%}-{hi:.0%})"


def rule_jam_probability(ctx: CheckContext) -> list[Finding]:
    """The fold under manufacturing and process scatter (``foldprint robust``)."""
    r = ctx.robust
    if r is None:
        return []
    lo, hi = r.ci95
    th = ctx.thresholds
    pairs = ", ".join(f"{a}-{b} ({k}x)" for (a, b), k in r.collisions()[:3])
    what = ("the printed geometry (arc hinges)" if r.hinge_model == HingeModel.ARC else
            f"the {r.hinge_model.value}-hinge model (not the printed geometry)")
    text = (f"jam probability {r.jam_probability:.0%} (95 % interval {lo:.0%}-{hi:.0%}) in {r.samples} samples "
            f"of {what} under scatter" + (f"; colliding: {pairs}" if pairs else ""))
    others = [p for p in ctx.sweep if p.scale != 1.0]
    if others:
        text += "; with the spreads scaled " + ", ".join(f"{p.scale:g}x: {_pct(p.result)}" for p in others)
    hint = "give neighbouring hinges materials further apart in Tg, so scatter cannot swap their order"
    verdict = jam_verdict(r, th)
    if verdict == "error":
        return [_f("FP180", "error", text + f": above the {th.error:.0%} error threshold even at the interval's "
                   "lower end", hint)]
    if verdict == "warning":
        return [_f("FP181", "warning", text + f": above the {th.warning:.0%} warning threshold", hint)]
    return [_f("FP182", "info", text)]


def rule_jam_sensitivity(ctx: CheckContext) -> list[Finding]:
    """FP183: the jam verdict flips inside the swept range of scatter spreads: a warning
    when it is worse at some scale than at the model's own spreads, info when only better."""
    r = ctx.robust
    if r is None or not ctx.sweep:
        return []
    th = ctx.thresholds
    rank = {"error": 0, "warning": 1, "info": 2}
    word = {"error": "fails (FP180)", "warning": f"jams above {th.warning:.0%} (FP181)", "info": "passes (FP182)"}
    base = jam_verdict(r, th)
    flips = [(p, jam_verdict(p.result, th)) for p in ctx.sweep if p.scale != 1.0]
    worse = [(p, v) for p, v in flips if rank[v] < rank[base]]
    better = [(p, v) for p, v in flips if rank[v] > rank[base]]
    if not worse and not better:
        return []
    shown = worse or better
    at = "; ".join(f"{word[v]} at {p.scale:g}x: {_pct(p.result)}" for p, v in shown)
    text = (f"the jam verdict depends on the scatter model: it {word[base]} at the model's spreads "
            f"({_pct(r)}) but {at} ({r.samples} samples each, the same draws)")
    if worse:
        return [_f("FP183", "warning", text, "most spreads are our choices, not measurements "
                   "(docs/robustness-model.md): measure your bath, hinges and heat transfer (--scatter FILE) or "
                   "give the design more margin")]
    return [_f("FP183", "info", text)]


def rule_hole_walls(ctx: CheckContext) -> list[Finding]:
    """FP112: the material left between a hole and the panel's outline (or between two
    holes) must be at least the printer's minimum wall, or the frame breaks or is not printed."""
    from itertools import combinations

    from shapely.geometry import LinearRing

    w = ctx.printer.min_wall_mm
    out = []
    for p in ctx.design.panels:
        rings = [LinearRing(h) for h in p.holes]
        outer = LinearRing(p.outline)
        walls = [(r.distance(outer), f"hole {k} and the outline") for k, r in enumerate(rings)]
        walls += [(rings[a].distance(rings[b]), f"holes {a} and {b}") for a, b in combinations(range(len(rings)), 2)]
        for dist, between in walls:
            if dist < w:
                out.append(_f("FP112", "error", f"panel {p.id!r}: the wall between {between} is {dist:.3g} mm, "
                              f"below the {w:g} mm minimum wall of {ctx.printer.name}",
                              f"move or shrink the hole to leave at least {w:g} mm", panel=p.id))
    return out


RULES = [rule_build_volume, rule_buildable, rule_min_wall, rule_hole_walls, rule_min_gap, rule_hinge_strain, rule_hinge_fits,
         rule_temperatures, rule_fold_within_duration, rule_folding, rule_jam_probability, rule_jam_sensitivity]


def run_checks(ctx: CheckContext, rules=None) -> list[Finding]:
    """Every rule's findings, errors first. The context comes from
    :func:`foldprint.apps.pipeline.evaluate` (or, for a subset of rules, from the caller)."""
    findings: list[Finding] = []
    for rule in rules or RULES:
        findings.extend(rule(ctx))
    order = {s: i for i, s in enumerate(SEVERITIES)}
    return sorted(findings, key=lambda f: (order[f.severity], f.code))

