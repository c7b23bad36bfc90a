"""Plain-data (JSON-ready) reports of results. The CLI prints them; nothing here writes."""

from __future__ import annotations

import math

from ..core.constants import JSON_DECIMALS
# the one formatter (callers import it from here too)
from ..core.display import jam_estimate_text, percent, seconds, threshold  # noqa: F401
from ..core.modes import JamReason, JamVerdict, SpreadBasis


def _r(x, nd=JSON_DECIMALS):
    if x is None:
        return None
    x = float(x)
    return None if not math.isfinite(x) else round(x, nd)


#: The verdict of a jam test as a finding's severity (FP180 error, FP181 warning, FP182 info).
VERDICT_SEVERITY = {JamVerdict.ERROR: "error", JamVerdict.WARNING: "warning", JamVerdict.PASS: "info"}


def answer_text(d) -> str:
    """What a jam test's decision (:class:`foldprint.simulation.jamtest.verdict.JamDecision`) says,
    as a verb phrase: "passes", "warns", "fails", or a one-threshold answer that leaves two
    verdicts open: "does not pass (above 5 %)", "does not fail (below 20 %)", or none: "is
    undecided at its maximum of 400 samples (p on the 5 % threshold)"."""
    vs = d.verdicts
    if d.undecided_at_max:
        return (f"is undecided at its maximum of {d.samples} samples (p on the "
                f"{threshold(d.test.asked.threshold)} threshold)")
    if len(vs) == 1:
        return {JamVerdict.PASS: "passes", JamVerdict.WARNING: "warns", JamVerdict.ERROR: "fails"}[vs[0]]
    if vs == (JamVerdict.WARNING, JamVerdict.ERROR):
        return f"does not pass (above {threshold(d.test.warning.threshold)})"
    return f"does not fail (below {threshold(d.test.error.threshold)})"


#: What a scatter spread rests on, as messages say it.
BASIS_TEXT = {SpreadBasis.MEASURED: "measured", SpreadBasis.DATASHEET: "from a datasheet",
              SpreadBasis.LITERATURE: "from the literature", SpreadBasis.CHOICE: "our choice, not measured"}


def basis_text(basis: SpreadBasis | None) -> str:
    """What a spread rests on, in words ("our choice, not measured"; "basis not stated").

    >>> basis_text(SpreadBasis.DATASHEET), basis_text(None)
    ('from a datasheet', 'basis not stated')
    """
    return "basis not stated" if basis is None else BASIS_TEXT[basis]


def jam_test_text(r) -> str:
    """How the jam test decided: its error rates, the samples it used of its maximum, and
    "truncated" when it reached the maximum undecided (a marginal design)."""
    d = getattr(r, "decision", None)
    if d is None:
        return f"a fixed count of {r.samples} samples"
    t = d.test
    rates = (f"{threshold(t.warning.alpha)} error rates" if len({t.warning.alpha, t.warning.beta, t.error.alpha,
                                                                 t.error.beta}) == 1 else "stated error rates")
    how = (f"truncated at the maximum of {t.max_samples} samples: the probability is close to a threshold"
           if d.truncated else f"decided after {d.samples} of at most {t.max_samples} samples")
    return f"sequential test, {rates}, {how}"


def jam_test_json(d) -> dict | None:
    """A jam test's decision (:class:`foldprint.simulation.jamtest.verdict.JamDecision`), None for a
    fixed-size estimate."""
    if d is None:
        return None
    t = d.test

    def one(sprt, outcome) -> dict:
        return {"threshold": sprt.threshold, "indifference": [sprt.lo, sprt.hi], "alpha": sprt.alpha,
                "beta": sprt.beta, "accepted": None if outcome.side is None else str(outcome.side),
                "at_samples": outcome.at, "truncated": outcome.truncated}

    lo, hi = d.interval
    return {"name": t.name, "verdict": str(d.verdict), "samples": d.samples, "jams": d.jams,
            "estimate": _r(d.estimate), "interval": [_r(lo), _r(hi)], "interval_name": d.interval_name,
            "level": t.level, "max_samples": t.max_samples, "truncated": d.truncated,
            "warning": one(t.warning, d.warning), "error": one(t.error, d.error)}


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
        "interval": r.interval_name,
        "test": jam_test_json(r.decision),
        "jams": r.jams,
        "failures": reasons,
        "collisions": [{"pair": list(p), "count": k} for p, k in r.collisions()],
        "fold_time_s": None if ft is None else {k: _r(v) for k, v in ft.items()},
        "scatter": r.scatter.to_json(),
        "nominal": simulation_json(r.nominal, brief=True),
    }


def estimate_json(r) -> dict:
    """The short form of a jam-probability estimate: jams, samples, p and its interval
    (and, for a jam test, what it asked, the verdict or null when its one-threshold answer
    leaves two open, the ``verdicts`` left open, and whether it was truncated)."""
    lo, hi = r.ci95
    out = {"jams": r.jams, "samples": r.samples, "jam_probability": _r(r.jam_probability), "ci95": [_r(lo), _r(hi)]}
    d = getattr(r, "decision", None)
    if d is not None:
        out.update(question=d.test.question.value, verdict=None if d.verdict is None else str(d.verdict),
                   verdicts=[str(v) for v in d.verdicts], undecided=d.undecided_at_max, truncated=d.truncated)
    return out


def check_relation_json(r, check_seed: int, decision=None) -> dict:
    """How a fixed-size estimate (``robust``) relates to ``check``'s figure: check draws
    the same stream at its seed and stops when its test decides, so on that seed its
    figure is the first n of these samples (``decision``: check's test on them, None for
    another seed)."""
    out = {"seed": check_seed, "same_stream": decision is not None, "decided": False}
    if decision is None:
        out["text"] = (f"check draws seed {check_seed}, other samples than these (seed {r.seed}); run robust "
                       f"--seed {check_seed} to see check's stream")
    elif not decision.decided:
        out["text"] = (f"check's sequential test (seed {check_seed}, this stream) needs more than these "
                       f"{r.samples} samples (at most {decision.test.max_samples}): the probability is near a "
                       "threshold")
    else:
        word = {"error": "fails", "warning": "warns", "pass": "passes"}[str(decision.verdict)]
        out.update(decided=True, verdict=str(decision.verdict), samples=decision.samples, jams=decision.jams)
        out["text"] = (f"check's sequential test (seed {check_seed}, this stream) {word} after the first "
                       f"{decision.samples} of these samples ({decision.jams} jam); its figure is theirs, "
                       "this one is all of them")
    return out


def contributions_json(c) -> list[dict]:
    """Each scatter component's share (:class:`foldprint.simulation.sensitivity.Contributions`)."""
    basis = c.full.scatter.basis
    return [{"component": it.component.key, "scope": it.component.scope.value, "label": it.component.label,
             "spread": it.spread, "unit": it.component.unit,
             "basis": None if basis(it.component.key) is None else basis(it.component.key).value,
             "alone": estimate_json(it.alone), "all_but": estimate_json(it.without)} for it in c.items]


def sweep_json(points) -> list[dict]:
    """The sigma-scale sweep (:func:`foldprint.simulation.sensitivity.sweep`)."""
    return [{"scale": p.scale, **estimate_json(p.result)} for p in points]


def flip_drivers_json(flips) -> list[dict]:
    """What drives each flip of the jam verdict
    (:class:`foldprint.simulation.jamtest.flip_drivers.FlipDrivers`): per flip its scale, the
    verdicts at 1x and there, the drivers (or the strongest probe) and each probe (a
    component removed, or kept at its 1x spread, at the flipping scale)."""
    out = []
    for fd in flips:
        strongest = fd.strongest
        out.append({
            "scale": fd.scale, "verdict_at_1x": str(fd.base.decision.verdict),
            "verdict": None if fd.flipped.decision.verdict is None else str(fd.flipped.decision.verdict),
            "verdicts": [str(v) for v in fd.flipped.decision.verdicts], "worse": fd.worse,
            "probe": "removed" if fd.worse else "kept at its 1x spread",
            "drivers": [pr.component.key for pr in fd.drivers],
            "strongest": None if strongest is None else strongest.component.key,
            "probes": [{"component": pr.component.key, "label": pr.component.label,
                        "scope": pr.component.scope.value, "spread": pr.spread, "probe_spread": pr.probe_spread,
                        "unit": pr.component.unit, "basis": None if pr.basis is None else pr.basis.value,
                        "source": pr.source, "restores": pr.restores, "toward_1x": _r(fd.toward_base(pr)),
                        **estimate_json(pr.result)} for pr in fd.probes]})
    return out


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
            "sensitivity": sweep_json(ev.sweep) if ev.sweep else None,
            "flip_drivers": flip_drivers_json(ev.flip_drivers) if ev.sweep else None,
            "paper": [line.to_json() for line in ev.paper_lines()]}


def simulate_json(result, comparison=None, printed_crossings=(), clearance=None, margin=None, paper=()) -> dict:
    """The ``foldprint simulate --json`` object: :func:`simulation_json` of the run, the
    panel pairs that cross in the printed state (a part that cannot be printed is not "a
    contact at t"), the other hinge model's verdict when it differs (a
    :class:`foldprint.apps.pipeline.Comparison`, left out when the part cannot be printed),
    the smallest ``clearance`` along the fold (a :class:`~foldprint.collision.clearance.Gap`),
    whether scatter closes it (``scatter_margin``, a
    :class:`~foldprint.simulation.margin.ScatterMargin`, when the fold completes) and the
    ``paper``'s statements beside the model's values (:class:`~foldprint.simulation.paper_beside.PaperLine`)."""
    report = simulation_json(result)
    crossing = [list(pair) for pair in printed_crossings]
    report["printed_crossings"] = crossing
    report["comparison"] = None if comparison is None or crossing else dict(
        simulation_json(comparison.result, brief=True), hinge_model=comparison.hinge_model.value)
    report["clearance"] = None if clearance is None else clearance.to_json()
    report["scatter_margin"] = None if margin is None else margin.to_json()
    report["paper"] = [line.to_json() for line in paper]
    return report


def robust_report_json(r, contributions=None, sweep=None) -> dict:
    """The ``foldprint robust --json`` object: :func:`robust_json` with each component's
    contribution and the sigma-scale sweep (None when not run)."""
    out = robust_json(r)
    out["contributions"] = None if contributions is None else contributions_json(contributions)
    out["sensitivity"] = None if sweep is None else sweep_json(sweep)
    return out


def finding_lines(findings) -> list[str]:
    """``check``'s text lines of its findings (``code``, ``severity``, ``message``,
    ``where``, ``hint``), a hint under its finding. A code found more than
    :data:`~foldprint.core.display.LIST_FIRST` + 1 times (one per hinge of a long
    strip) shows its first :data:`~foldprint.core.display.LIST_FIRST` and one line
    counting the rest (:func:`more_findings`); ``--json`` lists every one."""
    from ..core.display import clip_by

    out = []
    for f, rest in clip_by(findings, lambda f: f.code):
        where = ", ".join(f"{k} {v}" for k, v in f.where.items())
        out.append(f"{f.severity.upper():<7} {f.code} {f.message}" + (f" [{where}]" if where else ""))
        if f.hint:
            out.append(f"        hint: {f.hint}")
        if rest:
            out.append(f"{f.severity.upper():<7} {f.code} {more_findings(rest)}; --json lists every one")
    return out


def more_findings(rest) -> str:
    """"... and 93 more like these (hinge h7, hinge h8, ... and 87 more)": the findings of a
    code a text leaves out (``where`` as a dict, or ``where`` of a finding's JSON)."""
    from ..core.display import first_few

    at = [", ".join(f"{k} {v}" for k, v in (f["where"] if isinstance(f, dict) else f.where).items()) for f in rest]
    return f"... and {len(rest)} more like these" + (f" ({first_few(at)})" if all(at) else "")
