"""Plain-data (JSON-ready) reports of results. The CLI prints them; nothing here writes."""

from __future__ import annotations

import math

from ..core.modes import JamReason


def _r(x, nd=4):
    if x is None:
        return None
    x = float(x)
    return None if not math.isfinite(x) else round(x, nd)


def contact_json(c) -> dict:
    out = {"time_s": _r(c.time), "panels": list(c.panels), "method": c.method}
    if all(math.isfinite(v) for v in c.point):
        out["point_mm"] = [_r(v, 3) for v in c.point]
    return out


def mechanics_json(sol, design) -> dict:
    """The ``mechanics`` block of ``simulate --json``: ``{"model": "rigid"}``, or the
    bar-and-hinge run (docs/mechanics.md): its size and solver effort, the largest panel
    strain and diagonal fold, and per solved time step the largest of each."""
    if sol is None:
        return {"model": "rigid"}
    strain, bend = sol.panel_strain.max(axis=0), sol.panel_bending.max(axis=0)
    worst = max(range(len(strain)), key=lambda k: strain[k]) if len(strain) else None
    return {
        "model": "bar-hinge", "nodes": len(sol.model.nodes), "bars": len(sol.model.bars),
        "fold_springs": int(sol.model.fold.sum()), "bending_springs": int((~sol.model.fold).sum()),
        "newton_iterations": int(sol.iterations), "split_steps": int(sol.splits),
        "unconverged_at_s": [_r(t) for t in sol.unconverged],
        "max_panel_strain": _r(sol.max_strain, 6), "max_panel_bending_deg": _r(math.degrees(sol.max_bending), 3),
        "worst_panel": None if worst is None else design.panels[worst].id,
        "panel_strain_limit": sol.strain_limit, "above_limit": bool(sol.max_strain > sol.strain_limit),
        "panels": [{"id": p.id, "max_strain": _r(float(strain[k]), 6),
                    "max_bending_deg": _r(math.degrees(float(bend[k])), 3)} for k, p in enumerate(design.panels)],
        "steps": {"time_s": [_r(t) for t in sol.grid],
                  "max_panel_strain": [_r(float(v), 6) for v in sol.panel_strain.max(axis=1, initial=0.0)],
                  "max_panel_bending_deg": [_r(math.degrees(float(v)), 3)
                                            for v in sol.panel_bending.max(axis=1, initial=0.0)],
                  "energy_mj": [_r(float(v), 6) for v in sol.energy]},
    }


def simulation_json(result, brief: bool = False) -> dict:
    """The ``foldprint simulate --json`` object (``brief``: the verdict only)."""
    traj = result.trajectory
    design = result.design
    if brief:
        return {"completed": bool(result.completed),
                "fold_time_s": _r(result.fold_time) if result.completed else None,
                "first_collision": contact_json(result.first_collision) if result.first_collision else None,
                "goals": [g.to_json() for g in result.goals], "hinge_model": str(traj.model)}
    err = result.final_angle_error()
    hinges = []
    for k, h in enumerate(design.hinges):
        hinges.append({
            "id": h.id, "material": h.material,
            "fold_time_s": None if h.id in result.arrested else _r(traj.fold_times[k]),
            "onset_time_s": _r(traj.onset_times[k]),
            "target_angle_deg": _r(math.degrees(h.angle), 3),
            "final_angle_deg": _r(math.degrees(traj.angles[-1, k]), 3),
            "angle_error_deg": _r(math.degrees(err[k]), 3),
            "arrested_at_s": _r(result.arrested.get(h.id)),
        })
    return {
        "design": design.name,
        "temperature_c": _r(traj.bath_c, 3),
        "completed": bool(result.completed),
        "fold_time_s": _r(result.fold_time) if result.completed else None,
        "first_collision": contact_json(result.first_collision) if result.first_collision else None,
        "contacts": [contact_json(c) for c in result.contacts],
        "hinges": hinges,
        "goals": [g.to_json() for g in result.goals],
        "method": str(result.method),
        "notes": list(result.notes),
        "hinge_model": str(traj.model),
        "after_contact": str(result.after_contact),
        "duration_s": _r(traj.times[-1]),
        "dt_s": _r(traj.times[1] - traj.times[0]) if len(traj.times) > 1 else None,
        "initial_contacts": [contact_json(c) for c in result.initial_contacts],
        "loops": loops_json(traj.loops),
        "mechanics": mechanics_json(result.compliant, design),
    }


def robust_json(r) -> dict:
    """The ``foldprint robust --json`` object (a :class:`foldprint.simulation.robust.RobustResult`)."""
    lo, hi = r.ci95
    ft = r.fold_time_percentiles()
    reasons = {k.value: sum(o.reason == k for o in r.outcomes) for k in JamReason}
    return {
        "design": r.design,
        "samples": r.samples,
        "seed": r.seed,
        "hinge_model": str(r.hinge_model),
        "mechanics": str(r.mechanics),
        "jam_probability": _r(r.jam_probability),
        "ci95": [_r(lo), _r(hi)],
        "jams": r.jams,
        "failures": reasons,
        "collisions": [{"pair": list(p), "count": k} for p, k in r.collisions()],
        "fold_time_s": None if ft is None else {k: _r(v) for k, v in ft.items()},
        "scatter": r.scatter.to_json(),
        "nominal": simulation_json(r.nominal, brief=True),
    }


def estimate_json(r) -> dict:
    """The short form of a jam-probability estimate: jams, samples, p and its interval."""
    lo, hi = r.ci95
    return {"jams": r.jams, "samples": r.samples, "jam_probability": _r(r.jam_probability), "ci95": [_r(lo), _r(hi)]}


def contributions_json(c) -> list[dict]:
    """Each scatter component's share (:class:`foldprint.simulation.sensitivity.Contributions`)."""
    return [{"component": it.component.key, "scope": it.component.scope.value, "label": it.component.label,
             "spread": it.spread, "unit": it.component.unit, "alone": estimate_json(it.alone),
             "all_but": estimate_json(it.without)} for it in c.items]


def sweep_json(points) -> list[dict]:
    """The sigma-scale sweep (:func:`foldprint.simulation.sensitivity.sweep`)."""
    return [{"scale": p.scale, **estimate_json(p.result)} for p in points]


def loops_json(sol) -> dict | None:
    """The loop solver's report (hinge graphs with loops), None for a hinge tree."""
    if sol is None:
        return None
    return {"loops": sol.n_loops, "dof": sol.dof, "closure_residual": float(sol.closure),
            "locked_at_s": _r(sol.locked_at),
            "not_followed": [{"time_s": _r(t), "hinges": list(h)} for t, h in sol.stuck],
            "arc_gap_mm": _r(sol.arc_gap_mm, 4)}


def check_json(ev, printer_key: str) -> dict:
    """The ``foldprint check --json`` object of an :class:`~foldprint.apps.pipeline.Evaluation`
    (the command line and the gallery both write this one)."""
    findings = ev.findings
    return {"design": ev.design.name, "printer": printer_key,
            "hinge_model": str(ev.simulation.trajectory.model.value),
            "ok": ev.errors == 0, "errors": ev.errors,
            "warnings": sum(f.severity == "warning" for f in findings),
            "findings": [f.to_json() for f in findings],
            "robust": None if ev.robust is None else robust_json(ev.robust),
            "sensitivity": sweep_json(ev.sweep) if ev.sweep else None}


def simulate_json(result, comparison=None, printed_crossings=()) -> dict:
    """The ``foldprint simulate --json`` object: :func:`simulation_json` of the run, the
    panel pairs that cross in the printed state (a part that cannot be printed is not "a
    contact at t": issue 18), and the other hinge model's verdict when it differs (a
    :class:`foldprint.apps.pipeline.Comparison`, left out when the part cannot be printed)."""
    report = simulation_json(result)
    crossing = [list(pair) for pair in printed_crossings]
    report["printed_crossings"] = crossing
    report["comparison"] = None if comparison is None or crossing else dict(
        simulation_json(comparison.result, brief=True), hinge_model=comparison.hinge_model.value)
    return report


def robust_report_json(r, contributions=None, sweep=None) -> dict:
    """The ``foldprint robust --json`` object: :func:`robust_json` with each component's
    contribution and the sigma-scale sweep (None when not run)."""
    out = robust_json(r)
    out["contributions"] = None if contributions is None else contributions_json(contributions)
    out["sensitivity"] = None if sweep is None else sweep_json(sweep)
    return out
