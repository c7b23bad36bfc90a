"""The paper's statements about its structures (``foldprint/data/paper_timings.toml``) and
a design's link to them.

Every statement Mao et al. (2015) make about *when* (or whether) something happens to a
structure they printed has an id, the quote, its figure and source, and how the model's
value of it is read off a simulation (``measure``). A design taken from the paper names
the structure and the statements that are about it (:class:`PaperRef`, the ``[paper]``
table of a design file); ``simulate``, ``check`` and the gallery print each statement
beside the model's value (:mod:`foldprint.simulation.paper_beside`).
"""

from __future__ import annotations

import tomllib
from dataclasses import dataclass
from functools import lru_cache
from importlib import resources

from ..core.errors import DesignError

#: How the paper's number is read (docs/structure-timings.md).
KINDS = ("about", "at_most", "at_least", "none", "qualitative")
#: How the model's value is read off a simulation of the structure
#: (:func:`foldprint.simulation.paper_beside.model_value`): the first contact, when the
#: motion ends short of the target, the fold time (every hinge at 98 %), the last / first
#: of ``hinges`` to reach 5 % or 98 %, the order of ``materials``' curves, the goals met
#: in order; ``free_hinges``: not a structure (Fig. 1b, free hinges), measured apart.
#: "fitted": the shipped recovery parameters were fitted to the statement (agreement is by
#: construction, a calibration regression); "predicted": used in no fit (agreement is
#: validation).
ROLES = ("fitted", "predicted")
MEASURES = ("first_contact", "motion_end", "fold_time", "onset_last", "fold_last", "onset_first", "order",
            "goals", "free_hinges")


@dataclass(frozen=True)
class Statement:
    id: str
    what: str
    kind: str
    value_s: float | None
    quote: str
    source: str
    figure: str = ""
    measure: str = ""
    hinges: tuple[str, ...] = ()  # hinge ids the measure reads (onset_*, fold_last)
    materials: tuple[str, ...] = ()  # hinge materials whose order ``order`` reads
    role: str = "predicted"  # one of ROLES


@dataclass(frozen=True)
class Statements:
    approx_tol_s: float
    items: tuple[Statement, ...]

    def __getitem__(self, key: str) -> Statement:
        for s in self.items:
            if s.id == key:
                return s
        raise KeyError(key)

    @property
    def ids(self) -> tuple[str, ...]:
        return tuple(s.id for s in self.items)


def _statement(k: int, row: dict) -> Statement:
    where = f"paper_timings.toml: statement {k + 1} ({row.get('id')!r})"
    kind = row.get("kind")
    if kind not in KINDS:
        raise DesignError(f"{where}: kind {kind!r} is not one of {', '.join(KINDS)}")
    value = row.get("value_s")
    if kind in ("about", "at_most", "at_least") and not isinstance(value, (int, float)):
        raise DesignError(f"{where}: kind {kind} needs value_s")
    measure = row.get("measure", "")
    if measure not in MEASURES:
        raise DesignError(f"{where}: measure {measure!r} is not one of {', '.join(MEASURES)}")
    role = row.get("role")
    if role not in ROLES:
        raise DesignError(f"{where}: role {role!r} is not one of {', '.join(ROLES)}")
    return Statement(row["id"], row["what"], kind, None if value is None else float(value), row["quote"],
                     row["source"], row.get("figure", ""), measure, tuple(row.get("hinges", ())),
                     tuple(row.get("materials", ())), role)


@lru_cache(maxsize=1)
def load_statements() -> Statements:
    """The shipped statements (``foldprint/data/paper_timings.toml``)."""
    res = resources.files("foldprint") / "data" / "paper_timings.toml"
    data = tomllib.loads(res.read_text(encoding="utf-8"))
    items = tuple(_statement(k, row) for k, row in enumerate(data.get("statement", [])))
    return Statements(float(data["approx_tol_s"]), items)


@dataclass(frozen=True)
class PaperRef:
    """A design taken from the paper: how the paper names the structure (``name``, e.g.
    "Sample 1"), its ``figure``, and the ids of the statements about it."""

    name: str
    figure: str
    statements: tuple[str, ...] = ()

    def __post_init__(self):
        object.__setattr__(self, "statements", tuple(self.statements))

    @property
    def label(self) -> str:
        """"Sample 1 (Fig. 2)": how outputs name the structure."""
        return f"{self.name} ({self.figure})" if self.figure else self.name
