"""What drives a flip of ``check``'s jam verdict inside the sigma-scale sweep (FP183).

When the verdict at a scale k of the sweep differs from the one at the model's own
spreads (1x), the flip is taken apart at k: for each component with a non-zero spread,
check's sequential jam test runs again at k with that component removed (all but it), on
the same draws (the same seed: :mod:`foldprint.simulation.scatter` scales the same
standard normals, common random numbers). A component whose removal brings the verdict
back to the one at 1x, or past it, **drives** the flip: without it the flip does not
happen. When no removal does that alone, the flip needs several components together; the
one whose removal moves the estimate furthest toward the 1x verdict is reported as the
**strongest**, and said to be so.

Each component carries its basis (:class:`~foldprint.core.modes.SpreadBasis`: measured,
a datasheet, the literature, or our choice), so the report can say whether a flip rests
on a measured spread or on a chosen one (``docs/robustness-model.md``).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

from ..core.constants import CHECK_DT_S
from ..core.modes import JamVerdict, SpreadBasis
from ..model.design import Design
from ..model.materials import MaterialLibrary
from .robust import RobustResult
from .scatter import COMPONENTS, Component
from .sequential import StageProgress, jam_tests_of

#: The verdicts from best to worst.
_ORDER = (JamVerdict.PASS, JamVerdict.WARNING, JamVerdict.ERROR)


def worse(a: JamVerdict, b: JamVerdict) -> bool:
    """Whether verdict ``a`` is worse than ``b`` (pass < warning < error).

    >>> worse(JamVerdict.ERROR, JamVerdict.PASS), worse(JamVerdict.PASS, JamVerdict.PASS)
    (True, False)
    """
    return _ORDER.index(a) > _ORDER.index(b)


def undoes(base: JamVerdict, flipped: JamVerdict, without: JamVerdict) -> bool:
    """Whether a removal undoes a flip from ``base`` (1x) to ``flipped``: the verdict
    ``without`` the component is back at ``base`` or past it, away from ``flipped``.

    >>> P, W, E = JamVerdict.PASS, JamVerdict.WARNING, JamVerdict.ERROR
    >>> undoes(P, E, W), undoes(W, E, P), undoes(E, P, W), undoes(W, P, E)
    (False, True, False, True)
    """
    if base == flipped:
        raise ValueError(f"not a flip: {base} at 1x and at the scale")
    return not worse(without, base) if worse(flipped, base) else not worse(base, without)


@dataclass(frozen=True)
class Removal:
    """The jam test at the flipping scale with one component removed: the component, its
    spread there, what that spread rests on, the test's result, and whether removing the
    component undoes the flip (the verdict is back at the 1x verdict, or past it)."""

    component: Component
    spread: float
    basis: SpreadBasis | None
    source: str
    result: RobustResult
    restores: bool

    @property
    def verdict(self) -> JamVerdict:
        return self.result.decision.verdict


@dataclass(frozen=True)
class FlipDrivers:
    """One flip taken apart: the sweep's ``scale``, the test at 1x (``base``) and at the
    scale (``flipped``), and one :class:`Removal` per component with a non-zero spread."""

    scale: float
    base: RobustResult
    flipped: RobustResult
    removals: tuple[Removal, ...]

    @property
    def worse(self) -> bool:
        """The verdict at the scale is worse than at 1x (FP183's warning), else better."""
        return worse(self.flipped.decision.verdict, self.base.decision.verdict)

    def toward_base(self, removal: Removal) -> float:
        """How far removing ``removal``'s component moves the jam estimate toward the 1x
        verdict (the estimate at the scale minus without it, for a worse flip; the
        reverse for a better one; negative: away from it)."""
        moved = self.flipped.jam_probability - removal.result.jam_probability
        return moved if self.worse else -moved

    @property
    def drivers(self) -> tuple[Removal, ...]:
        """The components whose removal alone undoes the flip."""
        return tuple(r for r in self.removals if r.restores)

    @property
    def strongest(self) -> Removal | None:
        """When no component drives the flip alone: the removal that moves the estimate
        furthest toward the 1x verdict (None when there are drivers, or when no removal
        moves it toward the 1x verdict)."""
        if self.drivers or not self.removals:
            return None
        best = max(self.removals, key=self.toward_base)
        return best if self.toward_base(best) > 0 else None


def flip_drivers(design: Design, base: RobustResult, flips: Sequence, *, library: MaterialLibrary | None = None,
                 dt: float = CHECK_DT_S, workers: int | None = None, mapper=None,
                 progress: StageProgress | None = None) -> tuple[FlipDrivers, ...]:
    """Take apart each flip of ``flips`` (sweep points: ``.scale`` and ``.result``, check's
    jam test at that scale, whose verdict differs from ``base``'s, the test at 1x): the
    same test (``base``'s seed, hinge model, collision method and test; time step ``dt``)
    with each component of non-zero spread removed, every run in one pool (``workers``,
    ``mapper`` and ``progress`` as :func:`~foldprint.simulation.sequential.jam_tests`)."""
    if base.decision is None or any(p.result.decision is None for p in flips):
        raise ValueError("flip drivers take check's sequential jam tests (results with a decision)")
    if any(p.result.decision.verdict == base.decision.verdict for p in flips):
        raise ValueError("a flip's verdict must differ from the verdict at 1x")
    runs = {}
    for p in flips:
        sc = p.result.scatter
        for c in COMPONENTS:
            if sc.spread(c.key) > 0:
                runs[f"flip at {p.scale:g}x, without {c.key}"] = (p, c, sc.without(c.key))
    if not runs:
        return ()
    got = jam_tests_of(design, base.decision.test, {name: sc for name, (_, _, sc) in runs.items()}, base.seed,
                       library=library, hinge_model=base.hinge_model, dt=dt, method=base.method,
                       nominal=base.nominal, workers=workers, mapper=mapper, progress=progress)
    out = []
    for p in flips:
        was, flipped = base.decision.verdict, p.result.decision.verdict
        removals = []
        for name, (q, c, _) in runs.items():
            if q is not p:
                continue
            r, sc = got[name], p.result.scatter
            removals.append(Removal(c, sc.spread(c.key), sc.basis(c.key), sc.sources.get(c.key, ""), r,
                                    undoes(was, flipped, r.decision.verdict)))
        out.append(FlipDrivers(float(p.scale), base, p.result, tuple(removals)))
    return tuple(out)
