"""The jam-probability rules of the pre-print check (FP180-FP183): check's jam test under
manufacturing and process scatter, and where its verdict flips inside the swept range of
scatter spreads, with what drives each flip. The severities a jam estimate earns
(:func:`jam_verdict`) are public: the gallery and the tests read them.
"""

from __future__ import annotations

from ..core.modes import HingeModel, JamReason, SpreadBasis
from ..core.display import first_few
from .findings import CheckContext, Finding, Thresholds, finding
from .report import VERDICT_SEVERITY, answer_text, basis_text, jam_estimate_text, jam_test_text, threshold


def jam_verdict(r, th: Thresholds) -> str:
    """The severity a jam probability earns: its sequential test's verdict (``check``,
    :mod:`foldprint.simulation.jamtest.verdict`: error, warning or pass = info); for a fixed-size
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
        return [finding("FP180", "error", text + f": above the {threshold(th.error)} error threshold{above}{how}{tail}", hint)]
    if verdict == "warning":
        return [finding("FP181", "warning", text + f": above the {threshold(th.warning)} warning threshold{how}{tail}", hint)]
    return [finding("FP182", "info", text + f": below the {threshold(th.warning)} warning threshold{how}{tail}")]


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
        return [finding("FP183", "warning", text, _flip_hint(ctx.flip_drivers))]
    return [finding("FP183", "info", text)]


def _drivers_text(fd) -> str:
    """What drives one flip (:class:`~foldprint.simulation.jamtest.flip_drivers.FlipDrivers`): each
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
