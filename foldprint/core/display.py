"""How a number is shown to a user: every text output (the command line, the gallery and
viewer pages, the print recipe, the figures' labels) prints a time with :func:`seconds`
and a probability with :func:`percent`, so one design's number reads the same everywhere
(a threshold with :func:`threshold`, a jam estimate with :func:`jam_estimate_text`).
"""

from __future__ import annotations

from .constants import FOLD_LEVEL, JSON_DECIMALS, TIME_DECIMALS


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


LIST_FIRST = 6
"""How many items of a list that grows with the design a text output names before it
counts the rest ("h1, h2, h3, h4, h5, h6 and 94 more"); our choice: a line's worth."""


def first_few(items, first: int = LIST_FIRST) -> str:
    """Items named up to ``first``, the rest counted.

    >>> first_few(["a", "b"]), first_few([f"h{i}" for i in range(1, 11)], 3)
    ('a, b', 'h1, h2, h3 and 7 more')
    """
    items = [str(i) for i in items]
    if len(items) <= first:
        return ", ".join(items)
    return f"{', '.join(items[:first])} and {len(items) - first} more"


def clipped(lines: list[str], first: int = LIST_FIRST, what: str = "lines", where: str = "") -> list[str]:
    """The lines of a list that grows with the design: every one up to ``first`` + 1 (a
    summary line would not save one), else the first ``first`` and one line counting the
    rest ("... and 94 more hinges; --json lists every one"), indented as the first line.

    >>> clipped(["a", "b"], 1)
    ['a', 'b']
    >>> clipped(["a", "b", "c"], 1, "rows", "; the file lists them")
    ['a', '... and 2 more rows; the file lists them']
    """
    if len(lines) <= first + 1:
        return list(lines)
    pad = lines[0][:len(lines[0]) - len(lines[0].lstrip())]  # the summary indented as the lines
    return lines[:first] + [f"{pad}... and {len(lines) - first} more {what}{where}"]


def clip_by(items, key, first: int = LIST_FIRST) -> list[tuple[object, list]]:
    """A list whose items fall in groups (``key(item)``: a finding's code), each group
    clipped as :func:`clipped` clips a list: ``(item, rest)`` for every item shown, in
    order; ``rest`` is the group's items not shown, after the last shown item of a group
    longer than ``first`` + 1, else empty.

    >>> [(i, r) for i, r in clip_by([1, 2, 3, 10, 4], lambda x: x // 10, 2)]
    [(1, []), (2, [3, 4]), (10, [])]
    """
    items = list(items)
    groups: dict = {}
    for it in items:
        groups.setdefault(key(it), []).append(it)
    out, seen = [], {}
    for it in items:
        k = key(it)
        n = seen[k] = seen.get(k, 0) + 1
        group = groups[k]
        if len(group) <= first + 1:
            out.append((it, []))
        elif n <= first:
            out.append((it, group[first:] if n == first else []))
    return out


def hinge_text(h: dict) -> str:
    """A hinge's fold time as every output prints it (``h``: a hinge of the simulation's
    JSON), or why it does not fold: arrested at a contact, or short of 98 % of its target
    at the end (e.g. held by a loop's closure: its material's own time is then said beside
    it, never as the hinge's fold time)."""
    ft = "does not fold" if h["fold_time_s"] is None else seconds(h["fold_time_s"])
    if h["arrested_at_s"] is not None:
        return f"{ft}, arrested at {seconds(h['arrested_at_s'])}, {h['angle_error_deg']:.1f} deg short"
    if _short(h):
        alone = "" if h["fold_time_s"] is None else f" (its material alone folds in {ft})"
        return (f"does not fold: {round(h['final_angle_deg'], 1) + 0.0:.1f} of {h['target_angle_deg']:g} deg at the "
                f"end, short of {100 * FOLD_LEVEL:g} %{alone}")
    return ft


def _short(h: dict) -> bool:
    return abs(h["angle_error_deg"]) > (1 - FOLD_LEVEL) * abs(h["target_angle_deg"]) + 1e-9


def hinge_folds(h: dict) -> bool:
    """Whether a hinge of the simulation's JSON folds: its material recovers, nothing
    arrests it, and it ends within 98 % of its target."""
    return h["fold_time_s"] is not None and h["arrested_at_s"] is None and not _short(h)


def hinge_lines(hinges: list[dict], indent: str = "  ") -> list[str]:
    """``simulate``'s hinge rows (id, material, :func:`hinge_text`): every one for a few
    hinges; for many, the first :data:`LIST_FIRST` and one line counting the rest, those
    that fold (and by when) and those that do not (named up to :data:`LIST_FIRST`)."""
    rows = [f"{indent}{h['id']:<6} {h['material']:<6} {hinge_text(h)}" for h in hinges]
    if len(rows) <= LIST_FIRST + 1:
        return rows
    rest = hinges[LIST_FIRST:]
    folded = [h["fold_time_s"] for h in rest if hinge_folds(h)]
    stuck = [h["id"] for h in rest if not hinge_folds(h)]
    parts = ([f"{len(folded)} fold, the last at {seconds(max(folded))}"] if folded else []) + (
        [f"{len(stuck)} do not fold ({first_few(stuck)})"] if stuck else [])
    return rows[:LIST_FIRST] + [f"{indent}... and {len(rest)} more hinges: {'; '.join(parts)} (--json lists every one)"]
