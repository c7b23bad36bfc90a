"""How a number is shown to a user: every text output (the command line, the gallery and
viewer pages, the print recipe, the figures' labels) prints a time with :func:`seconds`
and a probability with :func:`percent`, so one design's number reads the same everywhere
(a threshold with :func:`threshold`, a jam estimate with :func:`jam_estimate_text`).
"""

from __future__ import annotations

from .constants import JSON_DECIMALS, TIME_DECIMALS


def seconds(t: float | None) -> str:
    """A time as every text output prints it: to :data:`~foldprint.core.constants.TIME_DECIMALS`
    decimals of a second, with its unit ("2.51 s"; an em dash for none). The time is
    rounded as the JSON outputs hold it (:data:`~foldprint.core.constants.JSON_DECIMALS`)
    first, so a page that prints a JSON value and one that prints the number it came from
    print the same string.

    >>> seconds(2.5149), seconds(None)
    ('2.51 s', '\u2014')
    >>> seconds(2.514996) == seconds(round(2.514996, 4))
    True
    """
    return "\u2014" if t is None else f"{round(float(t), JSON_DECIMALS):.{TIME_DECIMALS}f} s"


def percent(p: float) -> str:
    """A probability as every output prints it ("97.5 %")."""
    return f"{100 * float(p):.1f} %"


def threshold(p: float) -> str:
    """A threshold or error rate as a round percentage ("20 %", "2.5 %")."""
    return f"{100 * float(p):g} %"


def jam_estimate_text(r) -> str:
    """A jam probability with its interval and counts, as check, robust and the gallery
    print it: "97.5 % (95 % interval 91.3-99.3 %), 78 of 80 samples jam" (``r``: an
    estimate with ``ci95``, ``jam_probability``, ``jams`` and ``samples``)."""
    lo, hi = r.ci95
    return (f"{percent(r.jam_probability)} (95 % interval {100 * lo:.1f}-{percent(hi)}), "
            f"{r.jams} of {r.samples} samples jam")
