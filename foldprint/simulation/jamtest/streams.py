"""One Monte-Carlo stream of the adaptive pool (:mod:`foldprint.simulation.jamtest.pool`):
where it is (:class:`StreamStatus`, what progress reports), what it has folded and consumed
in stream order, and how big its next chunk is (:func:`to_decision`, :data:`MIN_CHUNK`,
:data:`LOOP_MIN_CHUNK`).
The pool decides which stream a free worker serves (costliest design first,
:func:`sample_cost`); a stream decides how much it is given and what it keeps.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

from ...model.design import Design, has_loops
from ..robust import CHUNK, Outcome
from ..scatter import Scatter
from .verdict import JamTest, decide


@dataclass(frozen=True)
class StreamStatus:
    """Where one (job, scale) stream is: samples consumed in order so far, its maximum,
    whether it is finished (its test decided, or every sample of a fixed job in), and the
    jams among the samples consumed (what a running estimate and its interval need)."""

    job: int
    scale: float
    samples: int
    max_samples: int
    done: bool
    jams: int = 0


#: The smallest chunk a sequential test's strip stream is given when its test could stop
#: sooner than :data:`~foldprint.simulation.robust.CHUNK` samples on. Our choice: a strip's
#: sample costs about the same in chunks of 4 as of 16 (measured on helix_graded, numpy
#: path: 26.9 against 26.6 CPU-ms), one of 1 about 1.5x; on the compiled kernels 8.2
#: against 7.0 CPU-ms, one of 1 14 (about 5 ms a chunk: its draws, one curve call per
#: material): the smaller chunk still folds fewer samples past a stop than it costs.
MIN_CHUNK = 4

#: The smallest chunk of a loop pattern's stream, cut where an unbroken run of clean
#: samples would stop its test (a jammed run does not cut it). Our choice: a loop pattern's
#: closure is tracked for a chunk's samples together, and a chunk costs about 50 CPU-ms
#: beside its samples' 23 each (``miura_3x3``, compiled: 16 samples 0.415 CPU-s, 9 0.27,
#: 4 0.14; one sample takes the reference tracker, 0.156), so 8 keeps a chunk's own cost
#: near a quarter of its samples' while a clean stream that stops after 57 folds 57
#: (16 + 16 + 16 + 9), not 64.
LOOP_MIN_CHUNK = 8


def to_decision(jammed: Sequence[bool], test: JamTest, limit: int, runs: Sequence[bool] = (False, True)) -> int:
    """The fewest further samples after ``jammed`` with which ``test`` can decide when they
    all come out alike (all clean or all jammed; ``runs``: only those), at most ``limit``:
    a chunk of that many cannot be folded past the stop by an unbroken run, the way a test
    ends most often."""
    jammed = list(jammed)
    best = limit
    for more in runs:
        d = decide(jammed + [more] * limit, test)
        if d.decided:
            best = min(best, d.samples - len(jammed))
    return max(1, best)


def sample_cost(design: Design) -> float:
    """Relative cost of one sample, for the order only (costliest first): the hinges,
    times 50 for a pattern with loops (its fold tracks the closure at every step;
    measured: miura_3x3's sample about 50x a helix strip's)."""
    return len(design.hinges) * (50.0 if has_loops(design) else 1.0)


class Stream:
    """One stream of a job: a scale of it (``k``), or a follow-up (``k`` its name), with its
    scatter model and test; the chunks submitted (by first sample), in flight and back, and
    the outcomes consumed in stream order (cut at the test's stop)."""

    def __init__(self, j: int, k, job, scatter: Scatter, test: JamTest | None):  # job: a pool.MonteCarloJob
        self.j, self.k, self.job, self.scatter, self.test = j, k, job, scatter, test
        self.max_samples = job.samples if test is None else test.max_samples  # a probe's may be lower
        self.next = 0  # the first sample of the next chunk to submit
        self.flying = 0
        self.back: dict[int, list[Outcome]] = {}  # chunks back out of order, by first sample
        self.outcomes: list[Outcome] = []
        self.done = self.max_samples == 0
        self.timed = False
        # a loop pattern's closure is tracked for a chunk's samples together (LOOP_MIN_CHUNK)
        self.loops = has_loops(job.design)
        self.floor = LOOP_MIN_CHUNK if self.loops else MIN_CHUNK

    @property
    def wants(self) -> bool:
        return not self.done and self.next < self.max_samples

    @property
    def sure(self) -> bool:
        """Its next chunk will be used: a fixed job, or nothing of it in flight."""
        return self.test is None or self.flying == 0

    @property
    def open_past_clean_run(self) -> bool:
        """A further chunk may be used even if every sample submitted comes out clean: a
        fixed job, or a test that such a run would not stop (a clean run is how a mostly
        clean stream goes on; a chunk after it would be folded and thrown away)."""
        if self.test is None:
            return True
        unconsumed = self.next - len(self.outcomes)
        return to_decision([o.jammed for o in self.outcomes], self.test, unconsumed + 1, (False,)) > unconsumed

    def size(self) -> int:
        """The next chunk's size: :data:`CHUNK`, or with a test and nothing in flight the
        samples its test needs at least before it can stop (:func:`to_decision`), not below
        :data:`MIN_CHUNK`: a strip whose test stops after 6 clean samples folds 6, not 16.
        A loop pattern's chunk ends where a clean run after the samples already submitted
        would stop its test (a jammed run does not cut it), not below :data:`LOOP_MIN_CHUNK`:
        a clean stream that stops after 57 folds 16 + 16 + 16 + 9."""
        left = self.max_samples - self.next
        if self.test is None or (self.flying and not self.loops):
            return min(CHUNK, left)
        jammed = [o.jammed for o in self.outcomes]
        if self.loops:
            unconsumed = self.next - len(self.outcomes)
            need = to_decision(jammed, self.test, CHUNK + unconsumed, (False,)) - unconsumed
        else:
            need = to_decision(jammed, self.test, CHUNK)
        return min(left, CHUNK, max(need, self.floor))

    def take(self, size: int | None = None) -> tuple[int, int]:
        """The next chunk, (first sample, size), now in flight."""
        size = self.size() if size is None else size
        start = self.next
        self.next += size
        self.flying += 1
        return start, size

    def add(self, start: int, out: list[Outcome]) -> bool:
        """A chunk came back; consume what is in order; True when this finished the stream."""
        self.flying -= 1
        if self.done:
            return False  # folded past the stop: discarded
        self.back[start] = out
        while len(self.outcomes) in self.back:
            self.outcomes.extend(self.back.pop(len(self.outcomes)))
        if self.test is not None:
            d = decide([o.jammed for o in self.outcomes], self.test)
            if d.decided:
                del self.outcomes[d.samples:]
                self.done = True
        if len(self.outcomes) >= self.max_samples:
            self.done = True
        return self.done

    def status(self) -> StreamStatus:
        return StreamStatus(self.j, self.k, len(self.outcomes), self.max_samples, self.done,
                            sum(o.jammed for o in self.outcomes))
