"""Design-rule checks before printing. Each rule is a function ``(ctx) -> list[Finding]``,
so one run reports every problem.

Codes are stable (documented in ``docs/checks.md``); severities: error (the part will not
print or fold), warning (it may not), info (a margin worth knowing).
"""

from __future__ import annotations

import math

import numpy as np

from ..model.design import has_loops, tangent_factor
from ..core.constants import tol
# the printer profiles live in model.printers; importable from here as before
from ..model.printers import (Printer, default_printer_key, default_voxel_printer_key,  # noqa: F401
                              load_printers, tool_fit)
from ..core.display import first_few
from .report import seconds
# the findings and the context live in checks.findings, the jam rules in checks.jam_rules;
# importable from here, the checks' public place, as before
from .findings import SEVERITIES, CheckContext, Finding, Thresholds, finding  # noqa: F401
from .jam_rules import rule_jam_probability, rule_jam_sensitivity


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
        return [finding("FP101", "info", f"part {size[0]:.1f} x {size[1]:.1f} x {size[2]:.1f} mm fits "
                   f"{ctx.printer.name} ({build[0]:g} x {build[1]:g} x {build[2]:g} mm)")]
    return [finding("FP100", "error", f"part {size[0]:.1f} x {size[1]:.1f} x {size[2]:.1f} mm does not fit the build "
               f"volume of {ctx.printer.name} ({build[0]:g} x {build[1]:g} x {build[2]:g} mm)",
               "scale the design down or choose a larger printer with --printer")]


def rule_tools(ctx: CheckContext) -> list[Finding]:
    """FP103 / FP104: the design's materials fit the printer's tools (FDM: one filament per
    material; PolyJet: resin channels, digital materials jetted from VeroWhite and
    TangoBlack), :func:`foldprint.model.printers.tool_fit`."""
    pr = ctx.printer
    if pr.tools is None:
        return []
    fit = tool_fit(pr, ctx.design.materials_used, ctx.library)
    if not fit.ok:
        return [finding("FP103", "error", f"the design needs {fit.needed} {pr.unit}, {pr.name} has {pr.tools}: "
                   + fit.summary(), fit.alternatives(load_printers().values()))]
    note = ("" if pr.base_resins else "; each is a filament of your choosing: the fold times and jam "
            "probability here are the model's for the paper's PolyJet digital SMPs, not for filaments")
    return [finding("FP104", "info", fit.summary() + note)]


def rule_buildable(ctx: CheckContext) -> list[Finding]:
    """The printed part could be built: its bodies are watertight and disjoint."""
    if ctx.assembly_error is None:
        return [finding("FP105", "info", note) for note in getattr(ctx.assembly, "notes", ())]
    loops = "do not close the loops" in ctx.assembly_error
    return [finding("FP102", "error", f"the printed part cannot be built: {ctx.assembly_error}",
               "move the target angles onto the pattern's folding path" if loops else
               "the panels or hinges overlap in the printed (permanent) state; change the target angles, "
               "lengths or holes")]


def rule_min_wall(ctx: CheckContext) -> list[Finding]:
    out = []
    w = ctx.printer.min_wall_mm
    for p in ctx.design.panels:
        if p.thickness < w:
            out.append(finding("FP110", "error", f"panel {p.id!r} is {p.thickness:g} mm thick, below the "
                          f"{w:g} mm minimum wall of {ctx.printer.name}",
                          f"make it at least {w:g} mm thick", panel=p.id))
    for h in ctx.design.hinges:
        thin = h.style.thin_mm if h.style.stepped else h.thickness
        if thin < w:
            out.append(finding("FP111", "warning" if thin >= 0.5 * w else "error",
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
            out.append(finding("FP120", "error", f"hinge {h.id!r}: slots of {h.style.slot_width_mm:g} mm are narrower "
                          f"than the {g:g} mm minimum gap and will fuse", f"use slot_width_mm >= {g:g}", hinge=h.id))
    for p in ctx.design.panels:
        for k, hole in enumerate(p.holes):
            from shapely.geometry import Polygon

            poly = Polygon(hole)
            minx, miny, maxx, maxy = poly.bounds
            if min(maxx - minx, maxy - miny) < g:
                out.append(finding("FP121", "error", f"panel {p.id!r} holes[{k}] is narrower than the {g:g} mm minimum gap",
                              "widen the hole", panel=p.id))
    for gap in ctx.printed_gaps:
        if gap.distance >= g:
            continue
        a, b = gap.panels
        msg = (f"panels {a!r} and {b!r} are {gap.distance:.2f} mm apart in the printed state, below the "
               f"{g:g} mm minimum gap: they would print fused" if gap.distance > 0 else
               f"panels {a!r} and {b!r} intersect in the printed (permanent) state")
        out.append(finding("FP122", "error", msg, "move the panels apart or change the target angles",
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
            out.append(finding("FP130", "error", f"hinge {h.id!r}: programming strain {eps:.0%} exceeds {mat.name}'s "
                          f"limit {mat.max_strain:.0%} ({how})", fix, hinge=h.id))
        elif eps > 0.8 * mat.max_strain:
            out.append(finding("FP131", "warning", f"hinge {h.id!r}: programming strain {eps:.0%} is within 20 % of "
                          f"{mat.name}'s limit {mat.max_strain:.0%} ({how})",
                          "increase the bend radius" if not centred else fix, hinge=h.id))
        if 2 * h.radius <= h.thickness and abs(h.angle) > math.radians(150):
            out.append(finding("FP132", "error", f"hinge {h.id!r}: radius {h.radius:g} mm is too tight for a "
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
                out.append(finding("FP140", "error", f"hinge {h.id!r}: its flat width {w:.2f} mm (R {h.radius:g} mm x "
                              f"{math.degrees(abs(h.angle)):.0f} deg) leaves almost nothing of panel {pid!r}",
                              "reduce the bend radius or enlarge the panel", hinge=h.id, panel=pid))
        if h.length < 0.5 * w:
            out.append(finding("FP141", "warning", f"hinge {h.id!r} is {h.length:.1f} mm long but {w:.1f} mm wide: "
                          "short hinges twist", "lengthen the fold line or reduce the radius", hinge=h.id))
    return out


def rule_temperatures(ctx: CheckContext) -> list[Finding]:
    out = []
    pr = ctx.design.process
    for h in ctx.design.hinges:
        tg = ctx.library[h.material].tg_c
        if pr.program_temperature_c <= tg:
            out.append(finding("FP150", "error", f"hinge {h.id!r} ({h.material}, Tg {tg:g} C): programming at "
                          f"{pr.program_temperature_c:g} C is not above Tg, so it cannot be programmed flat",
                          f"program above {tg + 15:g} C", hinge=h.id))
        if pr.bath_temperature_c <= tg:
            out.append(finding("FP151", "error", f"hinge {h.id!r} ({h.material}, Tg {tg:g} C): a {pr.bath_temperature_c:g} C "
                          "bath is below Tg, so it never folds", f"use a bath above {tg + 15:g} C", hinge=h.id))
        if pr.fix_temperature_c >= tg:
            out.append(finding("FP152", "error", f"hinge {h.id!r} ({h.material}, Tg {tg:g} C): fixing at "
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
            out.append(finding("FP160", "error", f"hinge {h.id!r} ({h.material}) does not reach 98 % within the "
                          f"{d.process.duration_s:g} s process" + ("" if ft is None else f" (needs {seconds(ft)})"),
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
        # a lower-Tg hint would send the designer on a search that cannot succeed
        hint = ("these panels cross in the printed (permanent) state (FP122): no hinge order or material "
                "avoids it; change the target angles, lengths or holes" if crossing else
                "give the hinges that must fold first lower-Tg materials, so these panels fold in sequence")
        out.append(finding("FP170", "error", f"panels {c.panels[0]!r} and {c.panels[1]!r} collide at {seconds(c.time)} "
                      f"while folding ({model} hinges, 3D swept check)", hint,
                      c.point if all(map(math.isfinite, c.point)) else None, panels=list(c.panels)))
    for g in res.goals:
        if not g.met:
            why = "never passes" if g.time is None else "passes out of order"
            out.append(finding("FP171", "error", f"goal {g.goal.id!r}: panel {g.goal.panel!r} {why} through "
                          f"holes[{g.goal.hole}] of {g.goal.target!r} (holes count from 0)",
                          "adjust the hinge sequence", goal=g.goal.id))
    gap = ctx.clearance
    if c is None and gap is not None:
        out.append(finding("FP172", "info", f"smallest clearance between non-adjacent panels while folding: "
                      f"{gap.distance:.2f} mm ({gap.panels[0]!r}-{gap.panels[1]!r} at {seconds(gap.time)}, "
                      f"{model} hinges)", "", panels=list(gap.panels)))
    return out




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
                out.append(finding("FP112", "error", f"panel {p.id!r}: the wall between {between} is {dist:.3g} mm, "
                              f"below the {w:g} mm minimum wall of {ctx.printer.name}",
                              f"move or shrink the hole to leave at least {w:g} mm", panel=p.id))
    return out


def rule_mechanics(ctx: CheckContext) -> list[Finding]:
    """FP190: the rigid model locks the pattern (its loops lock, or creases that do not
    follow their drive end short of 98 %), so it folds, if at all, only with bending
    panels: the bar-and-hinge model is needed. FP191:
    the bar-and-hinge run strains a panel beyond the mechanics data's limit (warning) or
    reports the largest strain (info). docs/mechanics.md."""
    sim = ctx.simulation
    if sim is None:
        return []
    sol = sim.compliant
    if sol is None:
        loops = sim.trajectory.loops
        # lagging creases that still reach their targets (a Miura's least-squares compromise
        # mid-fold) are not locked: only a lock, or creases held short of 98 %, count
        if loops is None or (loops.locked_at is None and (not loops.stuck or all(sim.hinge_done))):
            return []
        at = loops.locked_at if loops.locked_at is not None else loops.stuck[0][0]
        ids = sorted({h for _, hs in loops.stuck for h in hs})
        return [finding("FP190", "warning", f"the rigid model cannot fold this pattern as driven: its loops lock at "
                   f"{at:.3g} s" + (f" (creases {first_few(ids)} do not follow their drive)" if ids else ""),
                   "panels that bend may let it fold: run foldprint simulate --mechanics bar-hinge "
                   "(docs/mechanics.md)")]
    worst = max(range(len(sim.design.panels)), key=lambda k: float(sol.panel_strain[:, k].max(initial=0.0)))
    pid = sim.design.panels[worst].id
    text = (f"bar-and-hinge model: largest panel strain {sol.max_strain:.3%} (panel {pid!r}), largest "
            f"diagonal fold {math.degrees(sol.max_bending):.2f} deg")
    if sol.max_strain > sol.strain_limit:
        return [finding("FP191", "warning", text + f", above the {sol.strain_limit:.1%} limit: the panels deform, "
                   "the rigid model does not apply", "stiffen or thicken the panels, or change the hinge "
                   "materials so the loops do not fight", panel=pid)]
    return [finding("FP191", "info", text + f", within the {sol.strain_limit:.1%} limit")]


RULES = [rule_build_volume, rule_tools, rule_buildable, rule_min_wall, rule_hole_walls, rule_min_gap, rule_hinge_strain,
         rule_hinge_fits, rule_temperatures, rule_fold_within_duration, rule_folding, rule_mechanics,
         rule_jam_probability, rule_jam_sensitivity]


def run_checks(ctx: CheckContext, rules=None) -> list[Finding]:
    """Every rule's findings, errors first. The context comes from
    :func:`foldprint.apps.pipeline.evaluate` (or, for a subset of rules, from the caller)."""
    findings: list[Finding] = []
    for rule in rules or RULES:
        findings.extend(rule(ctx))
    order = {s: i for i, s in enumerate(SEVERITIES)}
    return sorted(findings, key=lambda f: (order[f.severity], f.code))

