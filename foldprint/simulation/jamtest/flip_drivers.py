"""What drives a flip of ``check``'s jam verdict inside the sigma-scale sweep (FP183).

When the verdict at a scale k of the sweep differs from the one at the model's own
spreads (1x), the flip is taken apart at k, one component of non-zero spread at a time,
with check's sequential jam test on the same draws (the same seed:
:mod:`foldprint.simulation.scatter` scales the same standard normals, common random
numbers):

* a flip to a **worse** verdict (e.g. a pass at 1x, a failure at 2x): the test at k with
  the component **removed** (all but it). The component drives the flip when its removal
  brings the verdict back to the one at 1x, or past it: without it the flip does not
  happen.
* a flip to a **better** verdict (a failure at 1x, a warning at 0.5x): removing a spread
  can only make it better still, so the counterpart is asked: the test at k with the
  component **kept at its 1x spread** (the others at k). The component drives the flip
  when that brings the 1x verdict back: its smaller spread is what makes the part pass.

A probe asks only what decides that (:meth:`~foldprint.simulation.jamtest.verdict.JamTest.asking`):
which side of the one threshold between the 1x verdict and the flipped one the probe's p is
on (a pass at 1x: the warning threshold; a failure at 1x: the error threshold; a warning at
1x: the threshold the flip crossed), that threshold's test alone, with its error rates. A
probe far from that threshold stops early (a probe that stays a clear failure when a pass
was flipped stops once it is known to be above 5 %, not when it is known to be above 20 %);
its answer may leave two verdicts open ("above 5 %"). A probe folds at most
:data:`~foldprint.core.constants.PROBE_MAX_SAMPLES` samples; one that reaches them
without crossing either boundary of its test says so (its p is on the threshold) and claims
nothing: it is not counted as undoing the flip (a truncated test would decide by the sign
there, which inside the indifference region is either answer).

When no component does that alone, the flip needs several together; the probe that moves
the estimate furthest toward the 1x verdict is reported as the **strongest**, and said to
be so. Each component carries its basis (:class:`~foldprint.core.modes.SpreadBasis`:
measured, a datasheet, the literature, or our choice), so the report says whether a flip
rests on a measured spread or on a chosen one (``docs/robustness-model.md``).
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import NamedTuple, Sequence

from ...core.constants import CHECK_DT_S, PROBE_MAX_SAMPLES
from ...core.modes import JamQuestion, JamVerdict, SpreadBasis
from ...model.design import Design
from ...model.materials import MaterialLibrary
from ..robust import RobustResult
from ..scatter import COMPONENTS, Component, Scatter
from .scales import StageProgress, jam_tests_of
from .verdict import JamTest

#: The verdicts from best to worst.
_ORDER = (JamVerdict.PASS, JamVerdict.WARNING, JamVerdict.ERROR)


def worse(a: JamVerdict, b: JamVerdict) -> bool:
    """Whether verdict ``a`` is worse than ``b`` (pass < warning < error).

    >>> worse(JamVerdict.ERROR, JamVerdict.PASS), worse(JamVerdict.PASS, JamVerdict.PASS)
    (True, False)
    """
    return _ORDER.index(a) > _ORDER.index(b)


def undoes(base: JamVerdict, flipped: JamVerdict, probed: JamVerdict) -> bool:
    """Whether a probe undoes a flip from ``base`` (1x) to ``flipped``: its verdict
    ``probed`` is back at ``base`` or past it, away from ``flipped``.

    >>> P, W, E = JamVerdict.PASS, JamVerdict.WARNING, JamVerdict.ERROR
    >>> undoes(P, E, W), undoes(W, E, P), undoes(E, P, W), undoes(W, P, E)
    (False, True, False, True)
    """
    if base == flipped:
        raise ValueError(f"not a flip: {base} at 1x and at the scale")
    return not worse(probed, base) if worse(flipped, base) else not worse(base, probed)


def probe_question(base: JamVerdict, flipped: JamVerdict) -> JamQuestion:
    """The one threshold whose side decides whether a probe undoes a flip from ``base`` (1x)
    to ``flipped``: the one next to ``base`` on the flip's side.

    >>> P, W, E = JamVerdict.PASS, JamVerdict.WARNING, JamVerdict.ERROR
    >>> [probe_question(b, f).value for b, f in ((P, W), (P, E), (W, E), (W, P), (E, W), (E, P))]
    ['warning', 'warning', 'error', 'warning', 'error', 'error']
    """
    if base == flipped:
        raise ValueError(f"not a flip: {base} at 1x and at the scale")
    if base == JamVerdict.WARNING:
        return JamQuestion.ERROR if flipped == JamVerdict.ERROR else JamQuestion.WARNING
    return JamQuestion.WARNING if base == JamVerdict.PASS else JamQuestion.ERROR


def undoes_all(base: JamVerdict, flipped: JamVerdict, probed) -> bool:
    """Whether a probe undoes a flip whatever its verdict among ``probed`` (the verdicts its
    answer leaves open, :attr:`~foldprint.simulation.jamtest.verdict.JamDecision.verdicts`).

    >>> P, W, E = JamVerdict.PASS, JamVerdict.WARNING, JamVerdict.ERROR
    >>> undoes_all(P, E, (W, E)), undoes_all(W, E, (P, W)), undoes_all(E, W, (P, W)), undoes_all(P, W, (P,))
    (False, True, False, True)
    """
    if not probed:
        raise ValueError("a probe without an answer")
    return all(undoes(base, flipped, v) for v in probed)


@dataclass(frozen=True)
class Probe:
    """The jam test at the flipping scale with one component changed: the component, its
    spread at that scale and in the probe (0: removed, for a worse flip; its 1x spread,
    for a better one), what that spread rests on, the test's result (a one-threshold
    question, :func:`probe_question`), and whether the probe undoes the flip (:func:`undoes_all`)."""

    component: Component
    spread: float
    probe_spread: float
    basis: SpreadBasis | None
    source: str
    result: RobustResult
    restores: bool

    @property
    def verdicts(self) -> tuple[JamVerdict, ...]:
        """The verdicts the probe's answer leaves open (one, or two: "above 5 %")."""
        return self.result.decision.verdicts


@dataclass(frozen=True)
class FlipDrivers:
    """One flip taken apart: the sweep's ``scale``, the test at 1x (``base``) and at the
    scale (``flipped``), and one :class:`Probe` per component with a non-zero spread."""

    scale: float
    base: RobustResult
    flipped: RobustResult
    probes: tuple[Probe, ...]

    @property
    def worse(self) -> bool:
        """The verdict at the scale is worse than at 1x (FP183's warning), else better:
        the probes remove a component (worse) or keep it at its 1x spread (better)."""
        return worse(self.flipped.decision.verdicts[0], self.base.decision.verdict)

    def toward_base(self, probe: Probe) -> float:
        """How far ``probe`` moves the jam estimate toward the 1x verdict (down from the
        estimate at the scale for a worse flip, up for a better one; negative: away)."""
        moved = self.flipped.jam_probability - probe.result.jam_probability
        return moved if self.worse else -moved

    @property
    def drivers(self) -> tuple[Probe, ...]:
        """The probes whose component alone undoes the flip."""
        return tuple(p for p in self.probes if p.restores)

    @property
    def strongest(self) -> Probe | None:
        """When no component drives the flip alone: the probe that moves the estimate
        furthest toward the 1x verdict (None when there are drivers, or when no probe
        moves it toward the 1x verdict)."""
        if self.drivers or not self.probes:
            return None
        best = max(self.probes, key=self.toward_base)
        return best if self.toward_base(best) > 0 else None


def flips_of(base: RobustResult, points: Sequence) -> list:
    """The sweep points whose flip is taken apart (:func:`flipping` of their decisions)."""
    keep = set(flipping(base.decision.verdict, [(p.scale, p.result.decision) for p in points]))
    return [p for p in points if p.scale in keep]


def flipping(base: JamVerdict, points: Sequence[tuple]) -> list[float]:
    """The scales of the sweep points (``(scale, decision)``) whose flip is taken apart:
    those whose verdict is worse than ``base`` (the verdict at 1x), else those whose verdict
    is better (a sweep point's answer may leave two verdicts open, both on the same side of
    ``base``: :func:`~foldprint.simulation.jamtest.verdict.sweep_question`), in their order.

    >>> from types import SimpleNamespace as D
    >>> P, W, E = JamVerdict.PASS, JamVerdict.WARNING, JamVerdict.ERROR
    >>> flipping(W, [(0.5, D(verdicts=(P,))), (2.0, D(verdicts=(E,)))]), flipping(P, [(2.0, D(verdicts=(W, E)))])
    ([2.0], [2.0])
    """
    others = [(k, d) for k, d in points if k != 1.0]
    up = [k for k, d in others if all(worse(v, base) for v in d.verdicts)]
    return up or [k for k, d in others if all(worse(base, v) for v in d.verdicts)]


class ProbeRun(NamedTuple):
    """One probe to run: the flip's scale, the component changed, its spread in the probe,
    the scatter model and the one-threshold test it is folded under."""

    scale: float
    component: Component
    spread: float
    scatter: Scatter
    test: JamTest


def probe_runs(base, base_scatter: Scatter, flips: Sequence[tuple]) -> dict[str, ProbeRun]:
    """The probes of each flip (:class:`ProbeRun`), by the name progress gives them ("flip at
    2x, without bath"). ``base``: the
    decision at 1x (:class:`~foldprint.simulation.jamtest.verdict.JamDecision`) under
    ``base_scatter``; ``flips``: ``(scale, decision, scatter)`` of each flipped sweep point.
    One probe per component of non-zero spread: removed (a worse flip) or kept at its 1x
    spread (a better one), asking only the flip's threshold (:func:`probe_question`)."""
    if any(base.verdict in d.verdicts for _, d, _ in flips):
        raise ValueError("a flip's verdict must differ from the verdict at 1x")
    runs = {}
    for k, d, sc in flips:
        up = worse(d.verdicts[0], base.verdict)
        test = base.test.probing(probe_question(base.verdict, d.verdicts[0]), PROBE_MAX_SAMPLES)
        for c in COMPONENTS:
            if sc.spread(c.key) > 0:
                to = 0.0 if up else base_scatter.spread(c.key)
                name = f"flip at {k:g}x, " + (f"without {c.key}" if up else f"{c.key} at 1x")
                runs[name] = ProbeRun(float(k), c, to, replace(sc, **{c.attr: to}), test)
    return runs


def flip_drivers(design: Design, base: RobustResult, flips: Sequence, *, library: MaterialLibrary | None = None,
                 dt: float = CHECK_DT_S, workers: int | None = None, mapper=None,
                 progress: StageProgress | None = None) -> tuple[FlipDrivers, ...]:
    """Take apart each flip of ``flips`` (sweep points: ``.scale`` and ``.result``, check's
    jam test at that scale, whose verdict differs from ``base``'s, the test at 1x): the
    same test (``base``'s seed, hinge model, collision method, mechanics and test; time step ``dt``)
    with each component of non-zero spread removed (a worse flip) or kept at its 1x spread
    (a better one), asking only the flip's threshold (:func:`probe_runs`), every run in one
    pool (``workers``, ``mapper`` and ``progress`` as :func:`~foldprint.simulation.jamtest.scales.jam_tests`)."""
    if base.decision is None or any(p.result.decision is None for p in flips):
        raise ValueError("flip drivers take check's sequential jam tests (results with a decision)")
    runs = probe_runs(base.decision, base.scatter, [(p.scale, p.result.decision, p.result.scatter) for p in flips])
    if not runs:
        return ()
    got = jam_tests_of(design, {name: run.test for name, run in runs.items()},
                       {name: run.scatter for name, run in runs.items()}, base.seed,
                       library=library, hinge_model=base.hinge_model, dt=dt, method=base.method,
                       nominal=base.nominal, workers=workers, mapper=mapper, progress=progress,
                       mechanics=base.mechanics)
    out = []
    for p in flips:
        was, flipped, sc = base.decision.verdict, p.result.decision.verdicts[0], p.result.scatter
        probes = tuple(Probe(r.component, sc.spread(r.component.key), r.spread, sc.basis(r.component.key),
                             sc.sources.get(r.component.key, ""), got[name],
                             undoes_all(was, flipped, got[name].decision.verdicts))
                       for name, r in runs.items() if r.scale == p.scale)
        out.append(FlipDrivers(float(p.scale), base, p.result, probes))
    return tuple(out)
