"""Design-rule checks before printing. Each rule is a function ``(ctx) -> list[Finding]``,
so one run reports every problem.

Codes are stable (documented in ``docs/checks.md``); severities: error (the part will not
print or fold), warning (it may not), info (a margin worth knowing).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ..model.design import Design, has_loops, tangent_factor
from ..core.constants import JAM_ERROR_ABOVE, JAM_WARN_ABOVE, tol
from ..core.schema import jam_thresholds
from ..model.materials import MaterialLibrary
# the printer profiles live in model.printers; importable from here as before
from ..model.printers import (Printer, default_printer_key, default_voxel_printer_key,  # noqa: F401
                              load_printers, tool_fit)
from ..core.modes import HingeModel, JamReason, SpreadBasis
from ..core.display import first_few
from .report import VERDICT_SEVERITY, answer_text, basis_text, jam_estimate_text, jam_test_text, seconds, threshold

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
class Thresholds:
    """When the jam probability makes the pre-print check fail.

    ``error``: the check fails (exit 1) when the *lower* end of the 95 % interval is above
    this: the part jams more often than this even on the most favourable reading of the
    samples. ``warning``: a warning when the estimate itself is above this."""

    error: float = JAM_ERROR_ABOVE
    warning: float = JAM_WARN_ABOVE

    def __post_init__(self):
        jam_thresholds(self.error, self.warning)  # DesignError naming --error-above / --warn-above


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
    and ``.result``, :func:`foldprint.simulation.sensitivity.sweep`; empty when not run);
    ``flip_drivers``: what drives each flip FP183 reports
    (:func:`foldprint.simulation.flip_drivers.flip_drivers`; empty when not run)."""

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
    flip_drivers: tuple = ()


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


def rule_tools(ctx: CheckContext) -> list[Finding]:
    """FP103 / FP104: the design's materials fit the printer's tools (FDM: one filament per
    material; PolyJet: resin channels, digital materials jetted from VeroWhite and
    TangoBlack), :func:`foldprint.model.printers.tool_fit`."""
    pr = ctx.printer
    if pr.tools is None:
        return []
    fit = tool_fit(pr, ctx.design.materials_used, ctx.library)
    if not fit.ok:
        return [_f("FP103", "error", f"the design needs {fit.needed} {pr.unit}, {pr.name} has {pr.tools}: "
                   + fit.summary(), fit.alternatives(load_printers().values()))]
    note = ("" if pr.base_resins else "; each is a filament of your choosing: the fold times and jam "
            "probability here are the model's for the paper's PolyJet digital SMPs, not for filaments")
    return [_f("FP104", "info", fit.summary() + note)]


def rule_buildable(ctx: CheckContext) -> list[Finding]:
    """The printed part could be built: its bodies are watertight and disjoint."""
    if ctx.assembly_error is None:
        return [_f("FP105", "info", note) for note in getattr(ctx.assembly, "notes", ())]
    loops = "do not close the loops" in ctx.assembly_error
    return [_f("FP102", "error", f"the printed part cannot be built: {ctx.assembly_error}",
               "move the target angles onto the pattern's folding path" if loops else
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
        out.append(_f("FP170", "error", f"panels {c.panels[0]!r} and {c.panels[1]!r} collide at {seconds(c.time)} "
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
                      f"{gap.distance:.2f} mm ({gap.panels[0]!r}-{gap.panels[1]!r} at {seconds(gap.time)}, "
                      f"{model} hinges)", "", panels=list(gap.panels)))
    return out


def jam_verdict(r, th: Thresholds) -> str:
    """The severity a jam probability earns: its sequential test's verdict (``check``,
    :mod:`foldprint.simulation.verdict`: error, warning or pass = info); for a fixed-size
    estimate, error when the 95 % interval's lower end is above ``th.error``, warning when
    the estimate is above ``th.warning``, else info."""
    return jam_verdicts(r, th)[0]


def jam_verdicts(r, th: Thresholds) -> tuple[str, ...]:
    """The severities a jam probability may earn (:func:`jam_verdict`): one, or two when its
    test asked only whether a threshold is crossed (a sweep point: "above 5 %" leaves a
    warning and an error open), worst first."""
    d = getattr(r, "decision", None)
    if d is not None:
        return tuple(VERDICT_SEVERITY[v] for v in reversed(d.verdicts))
    return (_fixed_verdict(r, th),)


def _fixed_verdict(r, th: Thresholds) -> str:
    """A fixed-size estimate's severity (:func:`jam_verdict`)."""
    if r.ci95[0] > th.error:
        return "error"
    return "warning" if r.jam_probability > th.warning else "info"


def _thresholds(ctx: CheckContext) -> Thresholds:
    """The thresholds the jam probability was judged by: its test's, else the context's."""
    d = getattr(ctx.robust, "decision", None)
    return ctx.thresholds if d is None else Thresholds(d.test.error.threshold, d.test.warning.threshold)


def _scaled(points, th: Thresholds) -> str:
    """The sweep's other scales: each one's verdict and estimate."""
    return "; ".join(f"{p.scale:g}x: {_answer(p.result, th)}, {jam_estimate_text(p.result)}"
                     for p in points if p.scale != 1.0)


def _answer(r, th: Thresholds, codes: bool = False) -> str:
    """What a jam estimate says as a verb phrase ("fails", "does not pass (above 5 %)"),
    with the finding's code after a verdict when ``codes``."""
    d = getattr(r, "decision", None)
    if d is not None and len(d.verdicts) > 1:
        return answer_text(d)
    v = jam_verdict(r, th)
    word = {"error": "fails", "warning": f"jams above {threshold(th.warning)}", "info": "passes"} if codes else \
        {"error": "fails", "warning": "warns", "info": "passes"}
    return word[v] + (f" ({_CODE[v]})" if codes else "")


_CODE = {"error": "FP180", "warning": "FP181", "info": "FP182"}


def rule_jam_probability(ctx: CheckContext) -> list[Finding]:
    """The fold under manufacturing and process scatter: check's jam test (FP180-FP182)."""
    r = ctx.robust
    if r is None:
        return []
    th, d = _thresholds(ctx), getattr(r, "decision", None)
    pairs = first_few([f"{a}-{b} in {k}" for (a, b), k in r.collisions()], 3)
    what = ("the printed geometry (arc hinges)" if r.hinge_model == HingeModel.ARC else
            f"the {r.hinge_model.value}-hinge model (not the printed geometry)")
    text = f"jam probability {jam_estimate_text(r)}, {what} under scatter" + (f"; colliding: {pairs}" if pairs else "")
    how = f" ({jam_test_text(r)})"
    scaled = _scaled(ctx.sweep, th)
    tail = f"; with the spreads scaled {scaled}" if scaled else ""
    hint = jam_hint(r.outcomes)
    verdict = jam_verdict(r, th)
    if verdict == "error":
        above = "" if d is not None else " even at the interval's lower end"
        return [_f("FP180", "error", text + f": above the {threshold(th.error)} error threshold{above}{how}{tail}", hint)]
    if verdict == "warning":
        return [_f("FP181", "warning", text + f": above the {threshold(th.warning)} warning threshold{how}{tail}", hint)]
    return [_f("FP182", "info", text + f": below the {threshold(th.warning)} warning threshold{how}{tail}")]


def jam_hint(outcomes) -> str:
    """FP180/FP181's hint, by why the samples jam (each outcome's ``jammed`` and
    ``reason``): a collision or a pass-through out of order is an order scatter swapped,
    which hinges further apart in Tg prevent; samples that only stop short of their
    targets (a loop whose targets cannot close, a bath too cool, a run too short) jam
    whatever the scatter, and no Tg spacing helps."""
    reasons = [o.reason for o in outcomes if o.jammed]
    if not reasons or any(x in (JamReason.COLLISION, JamReason.GOAL) for x in reasons):
        return "give neighbouring hinges materials further apart in Tg, so scatter cannot swap their order"
    return (f"no sample collides or misses a goal: the {len(reasons)} jammed sample(s) stop short of their targets "
            "(a hinge below 98 % at the end of the run), which is not an order scatter swaps; `foldprint simulate` "
            "says which hinges and why (a loop whose targets cannot close, a bath too cool, a run too short)")


_RANK = {"error": 0, "warning": 1, "info": 2}


def sweep_flips(r, sweep, th: Thresholds = Thresholds()) -> tuple[list, bool]:
    """The sweep points FP183 reports, each with its verdict, and whether they are worse
    than ``r``'s verdict (the points where it is worse; when none is, those where it is
    better; none when no scale's verdict differs)."""
    base = jam_verdict(r, th)
    flips = [(p, jam_verdicts(p.result, th)) for p in sweep if p.scale != 1.0]
    worse = [(p, vs[0]) for p, vs in flips if all(_RANK[v] < _RANK[base] for v in vs)]
    return (worse, True) if worse else ([(p, vs[-1]) for p, vs in flips if all(_RANK[v] > _RANK[base] for v in vs)],
                                        False)


def rule_jam_sensitivity(ctx: CheckContext) -> list[Finding]:
    """FP183: the jam verdict flips inside the swept range of scatter spreads: a warning
    when it is worse at some scale than at the model's own spreads, info when only better.
    With ``ctx.flip_drivers`` the message names the components that drive each flip and
    what their spreads rest on (measured, datasheet, literature or our choice)."""
    r = ctx.robust
    if r is None or not ctx.sweep:
        return []
    th, d = _thresholds(ctx), getattr(r, "decision", None)
    shown, worse = sweep_flips(r, ctx.sweep, th)
    if not shown:
        return []
    at = "; ".join(f"{_answer(p.result, th, True)} at {p.scale:g}x: {jam_estimate_text(p.result)}" for p, _ in shown)
    same = "the same draws" if d is None else \
        "the same draws, each scale its own sequential test asking whether the verdict at 1x flips"
    text = (f"the jam verdict depends on the scatter model: it {_answer(r, th, True)} at the model's spreads "
            f"({jam_estimate_text(r)}) but {at} ({same})")
    text += "".join(f"; {_drivers_text(fd)}" for fd in ctx.flip_drivers)
    if worse:
        return [_f("FP183", "warning", text, _flip_hint(ctx.flip_drivers))]
    return [_f("FP183", "info", text)]


def _drivers_text(fd) -> str:
    """What drives one flip (:class:`~foldprint.simulation.flip_drivers.FlipDrivers`): each
    named component, what its spread rests on, and the test's verdict in its probe."""
    change = "without it" if fd.worse else "with it at its 1x spread"

    def probe(pr) -> str:
        return (f"{pr.component.label} ({pr.component.key}, {basis_text(pr.basis)}; {change} the test "
                f"{answer_text(pr.result.decision)}: {jam_estimate_text(pr.result)})")

    how = ("each scatter component removed in turn" if fd.worse else
           f"each scatter component in turn at its 1x spread, the others at {fd.scale:g}x") + ", the same draws"
    open_ = [pr for pr in fd.probes if pr.result.decision.undecided_at_max]
    unsure = "; undecided: the " + " and the ".join(map(probe, open_)) if open_ else ""
    if fd.drivers:
        return f"at {fd.scale:g}x the flip is driven by the " + " and by the ".join(map(probe, fd.drivers)) + \
            f"{unsure} ({how})"
    what = f"at {fd.scale:g}x no one component undoes the flip alone: it needs several together{unsure} ({how})"
    if fd.strongest is None:
        return f"{what}, and none of them moves the estimate back toward the verdict at 1x"
    return f"{what}; the one that moves the estimate most toward the verdict at 1x is the {probe(fd.strongest)}"


def _flip_hint(flip_drivers) -> str:
    """FP183's hint: measure the unmeasured spreads that drive the flip (or may: a probe
    undecided on its threshold), else more margin."""
    drive = [pr for fd in flip_drivers for pr in (fd.drivers or ((fd.strongest,) if fd.strongest else ()))]
    maybe = [pr for fd in flip_drivers for pr in fd.probes if pr.result.decision.undecided_at_max]
    unmeasured = {pr.component.key: basis_text(pr.basis) for pr in drive + maybe
                  if pr.basis in (None, SpreadBasis.CHOICE)}
    if unmeasured:
        rests = "rests" if {pr.component.key for pr in drive} & set(unmeasured) else "may rest"
        return (f"the flip {rests} on spreads nobody measured ({', '.join(f'{k}: {b}' for k, b in unmeasured.items())}): "
                "measure them and give them with their basis (--scatter FILE, basis = \"measured\"; "
                "docs/robustness-model.md), or give the design more margin")
    if drive or maybe:
        return "the spreads that drive the flip are not our choices: give the design more margin"
    return ("most spreads are our choices, not measurements (docs/robustness-model.md): measure your bath, hinges "
            "and heat transfer (--scatter FILE) or give the design more margin")


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
        return [_f("FP190", "warning", f"the rigid model cannot fold this pattern as driven: its loops lock at "
                   f"{at:.3g} s" + (f" (creases {first_few(ids)} do not follow their drive)" if ids else ""),
                   "panels that bend may let it fold: run foldprint simulate --mechanics bar-hinge "
                   "(docs/mechanics.md)")]
    worst = max(range(len(sim.design.panels)), key=lambda k: float(sol.panel_strain[:, k].max(initial=0.0)))
    pid = sim.design.panels[worst].id
    text = (f"bar-and-hinge model: largest panel strain {sol.max_strain:.3%} (panel {pid!r}), largest "
            f"diagonal fold {math.degrees(sol.max_bending):.2f} deg")
    if sol.max_strain > sol.strain_limit:
        return [_f("FP191", "warning", text + f", above the {sol.strain_limit:.1%} limit: the panels deform, "
                   "the rigid model does not apply", "stiffen or thicken the panels, or change the hinge "
                   "materials so the loops do not fight", panel=pid)]
    return [_f("FP191", "info", text + f", within the {sol.strain_limit:.1%} limit")]


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

