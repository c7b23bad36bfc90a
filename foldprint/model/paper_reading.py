"""One reading of the paper's words about time, used wherever a model value is judged
against one (``check``, ``simulate``, ``materials``, ``calibrate``, the gallery).

Each phrase means one stated interval (docs/structure-timings.md says why):

- "~X s" (``about``): [X - tol, X + tol];
- "within ~X s" and "by ~X s" (``at_most``): [0, X + tol];
- "after X s" (``at_least``): [X - tol, inf).

``tol`` is our reading of the paper's precision, not the paper's: its times are read off
video frames and written to the half second, so 0.5 s (``approx_tol_s`` of
``data/paper_timings.toml``). ``calibrate`` reads a lab's ``time_to`` / ``spread`` rows the
same way, with the row's sigma as the tolerance (0.5 s on the paper's rows). The model
meets a statement when its value lies in the interval; the tolerance is printed beside
every verdict (:meth:`Reading.text`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from .paper_statements import load_statements

#: The phrase each kind stands for.
PHRASES = {"about": "~{} s", "at_most": "within ~{} s", "at_least": "after {} s"}
#: Slack for floating point at the interval's ends (s).
EPS_S = 1e-9


@dataclass(frozen=True)
class Reading:
    """A stated time ``value_s`` of kind ``about`` / ``at_most`` / ``at_least`` read with
    tolerance ``tol_s`` (s) and where that tolerance comes from."""

    kind: str
    value_s: float
    tol_s: float
    tol_source: str = "our choice: the paper's times are to the half second"

    def __post_init__(self):
        if self.kind not in PHRASES:
            raise ValueError(f"no reading for kind {self.kind!r}; one of {', '.join(PHRASES)}")

    @property
    def low(self) -> float:
        return 0.0 if self.kind == "at_most" else self.value_s - self.tol_s

    @property
    def high(self) -> float:
        return math.inf if self.kind == "at_least" else self.value_s + self.tol_s

    @property
    def phrase(self) -> str:
        """The words: "within ~1 s"."""
        return PHRASES[self.kind].format(f"{self.value_s:g}")

    @property
    def interval_text(self) -> str:
        """"<= 1.5 s", ">= 2.5 s", "6.5-7.5 s"."""
        if self.kind == "at_most":
            return f"<= {self.high:g} s"
        if self.kind == "at_least":
            return f">= {self.low:g} s"
        return f"{self.low:g}-{self.high:g} s"

    @property
    def read_as(self) -> str:
        """"read as <= 1.5 s; tolerance 0.5 s, our choice: ..."."""
        return f"read as {self.interval_text}; tolerance {self.tol_s:g} s, {self.tol_source}"

    @property
    def text(self) -> str:
        """"within ~1 s, read as <= 1.5 s; tolerance 0.5 s, our choice: ..."."""
        return f"{self.phrase}, {self.read_as}"

    def meets(self, model_s: float) -> bool:
        return self.low - EPS_S <= model_s <= self.high + EPS_S

    def verdict(self, model_s: float | None) -> str:
        """"meets", "misses" or "never happens" (no model value)."""
        if model_s is None or (isinstance(model_s, float) and math.isnan(model_s)):
            return "never happens"
        return "meets" if self.meets(model_s) else "misses"

    def off_by(self, model_s: float) -> float:
        """How far ``model_s`` lies outside the interval (0 inside)."""
        return max(self.low - model_s, model_s - self.high, 0.0)


def paper_tolerance() -> float:
    """Our reading of the paper's "~" (s): ``approx_tol_s`` of ``data/paper_timings.toml``."""
    return load_statements().approx_tol_s


def read(kind: str, value_s: float, tol_s: float | None = None, tol_source: str | None = None) -> Reading:
    """The reading of one statement; ``tol_s`` None: :func:`paper_tolerance`."""
    tol = paper_tolerance() if tol_s is None else float(tol_s)
    return Reading(kind, float(value_s), tol, tol_source or Reading.tol_source)
