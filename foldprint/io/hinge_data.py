"""Hinge measurements for ``foldprint calibrate``: the CSV layout of ``docs/calibrate.md``.

One row per measurement, a header naming the columns (any order; blank cells where a kind
does not use the column), ``#`` starts a comment line. Kinds:

* ``ratio``   the recovery ratio R (0..1) at ``time_s`` of a hinge of ``material`` dropped
  from ``initial_c`` into a bath at ``bath_c`` (the protocol of the paper's Fig. 1b);
* ``angle``   the same measured as the angle between the panels, ``value`` in degrees (the
  paper's theta: 180 flat, ``printed_deg`` as printed, 90 by default);
* ``time_to`` the time (s, ``value``) at which R reaches ``level`` (0.98: the fold time);
  ``relation`` ``about`` (default), ``at_most`` or ``at_least`` (the paper's "within ~1 s",
  "after 3 s");
* ``spread``  the difference of two materials' ``time_to``: ``material`` minus ``reference``;
* ``tg``      a DMA tan-delta peak of ``material`` (deg C, ``value``);
* ``fixity``  a measured shape fixity of ``material`` (0..1, ``value``);
* ``storage``, ``loss``, ``tan_delta``: a DMA reading of ``material`` at ``temperature_c``
  and ``frequency_hz`` (E' or E'' in MPa, or tan delta = E''/E'; a temperature sweep at 1 Hz
  is the paper's protocol);
* ``relaxation`` the relaxation modulus E(t) (MPa) at ``time_s`` after a step strain held
  at ``temperature_c``.

``sigma`` is the row's standard uncertainty in its own unit (blank: the kind's default in
``foldprint/data/calibration.toml``); on the DMA kinds a relative one (a fraction of the
value); ``source`` is free text (where the number comes from).

Every file the command line reads goes through :func:`read_text` (one place: file type,
size limit, encoding).
"""

from __future__ import annotations

import csv
from dataclasses import dataclass
from pathlib import Path

from ..core.constants import DEFAULT_FIX_C, DEFAULT_THICKNESS_MM
from ..core.errors import DataError
from ..core.inputs import read_input, shown
from ..core.schema import (MAX_FILE_BYTES, MAX_LENGTH_MM, MIN_LENGTH_MM, TEMPERATURE_C, control_char, ident,
                           number_text)

COLUMNS = ("kind", "material", "reference", "bath_c", "thickness_mm", "initial_c", "time_s", "level",
           "value", "relation", "sigma", "printed_deg", "source", "temperature_c", "frequency_hz")
CURVE_KINDS = ("ratio", "angle")
TIME_KINDS = ("time_to", "spread")
PROPERTY_KINDS = ("tg", "fixity")
#: DMA readings: a temperature (or frequency) sweep, and stress relaxation.
DYNAMIC_KINDS = ("storage", "loss", "tan_delta")
DMA_KINDS = DYNAMIC_KINDS + ("relaxation",)
KINDS = CURVE_KINDS + TIME_KINDS + PROPERTY_KINDS + DMA_KINDS
RELATIONS = ("about", "at_most", "at_least")
#: The columns each kind needs, and the ones it may use; any other cell must be blank.
NEEDS = {"ratio": ("material", "bath_c", "time_s", "value"),
         "angle": ("material", "bath_c", "time_s", "value"),
         "time_to": ("material", "bath_c", "level", "value"),
         "spread": ("material", "reference", "bath_c", "level", "value"),
         "tg": ("material", "value"),
         "fixity": ("material", "value"),
         **{k: ("material", "temperature_c", "frequency_hz", "value") for k in DYNAMIC_KINDS},
         "relaxation": ("material", "temperature_c", "time_s", "value")}
_OBS = ("thickness_mm", "initial_c", "sigma", "source")
MAY = {"ratio": _OBS, "angle": _OBS + ("printed_deg",), "time_to": _OBS + ("relation",),
       "spread": _OBS + ("relation",), "tg": ("sigma", "source"), "fixity": ("sigma", "source"),
       **{k: ("sigma", "source") for k in DMA_KINDS}}
#: The DMA values a row may hold (lo, hi, unit; lo excluded): moduli from 1 Pa to 10 TPa
#: (a polymer's lie between ~0.01 MPa rubbery and ~10 GPa glassy: our wide choice, so that a
#: lab's unit slip, Pa for MPa, is refused), tan delta up to 100 (rubbers and glasses stay
#: below ~3).
DMA_VALUE = {"storage": (0.0, 1e7, "MPa"), "loss": (0.0, 1e7, "MPa"), "tan_delta": (0.0, 100.0, ""),
             "relaxation": (0.0, 1e7, "MPa")}
#: DMA frequencies (Hz, lo excluded; instruments span ~1e-3 to ~200 Hz) and relaxation times
#: (s, lo excluded; up to ~30 years): our wide choices.
FREQUENCY_HZ = (0.0, 1e6)
RELAXATION_S = (0.0, 1e9)
#: The paper's Fig. 1 hinge is printed at theta = 90 deg and programmed flat (180 deg).
PAPER_PRINTED_DEG = 90.0
MAX_ROWS = 200_000


def read_text(path: str | Path, what: str) -> str:
    """The text of the file at ``path`` (``what`` it should be, for messages), through the
    one door every input comes in by (:func:`foldprint.core.inputs.read_input`: a regular
    file, not a FIFO or device, of at most ``MAX_FILE_BYTES``), UTF-8 with or without a BOM.
    The one function calibrate reads files with."""
    raw = read_input(path, what, MAX_FILE_BYTES, DataError)
    try:
        return raw.decode("utf-8-sig")
    except UnicodeDecodeError:
        raise DataError(f"{shown(path)}: not a UTF-8 text file; expected {what}") from None


@dataclass(frozen=True)
class Observation:
    """One measurement the fit compares the model with (``ratio``, ``angle``, ``time_to``,
    ``spread`` rows). ``line`` is its line in the file (1 = the header)."""

    line: int
    kind: str
    material: str
    reference: str | None
    bath_c: float
    thickness_mm: float
    initial_c: float
    time_s: float | None
    level: float | None
    value: float
    relation: str
    sigma: float | None
    printed_deg: float
    source: str

    @property
    def curve(self) -> tuple:
        """The key of the curve (series) this row belongs to."""
        return (self.kind, self.material, self.reference, self.bath_c, self.thickness_mm, self.initial_c,
                self.level)


@dataclass(frozen=True)
class Property:
    """A measured material property (``tg`` or ``fixity`` row)."""

    line: int
    kind: str
    material: str
    value: float
    sigma: float | None
    source: str


@dataclass(frozen=True)
class DmaRow:
    """One DMA reading (``storage``, ``loss``, ``tan_delta`` at ``frequency_hz``, or
    ``relaxation`` at ``time_s``) of ``material`` at ``temperature_c``; ``sigma`` relative."""

    line: int
    kind: str
    material: str
    temperature_c: float
    frequency_hz: float | None
    time_s: float | None
    value: float
    sigma: float | None
    source: str


@dataclass(frozen=True)
class HingeData:
    """The rows of one measurement file."""

    source: str
    observations: tuple[Observation, ...]
    properties: tuple[Property, ...]
    dma: tuple[DmaRow, ...] = ()

    def dma_materials(self) -> list[str]:
        """Every material with DMA rows, in file order."""
        return list(dict.fromkeys(r.material for r in self.dma))

    def materials(self) -> list[str]:
        """Every material the observations name (``reference`` included), in file order."""
        out: list[str] = []
        for o in self.observations:
            for m in (o.material, o.reference):
                if m is not None and m not in out:
                    out.append(m)
        return out

    def _mean(self, kind: str, material: str) -> float | None:
        vals = [p.value for p in self.properties if p.kind == kind and p.material == material]
        return float(sum(vals) / len(vals)) if vals else None

    def tg(self, material: str) -> float | None:
        """The mean of ``material``'s ``tg`` rows (deg C), None without any."""
        return self._mean("tg", material)

    def fixity(self, material: str) -> float | None:
        """The mean of ``material``'s ``fixity`` rows, None without any."""
        return self._mean("fixity", material)

    def property_source(self, kind: str, material: str) -> str:
        rows = [p for p in self.properties if p.kind == kind and p.material == material]
        return "; ".join(sorted({p.source for p in rows if p.source})) or f"{self.source} lines " + \
            ", ".join(str(p.line) for p in rows)


class _Cell:
    """Where a cell is, for messages: ``file: line N, column C (kind K): ...``."""

    def __init__(self, src: str, line: int, column: str, kind: str):
        self.src, self.line, self.column, self.kind = src, line, column, kind

    def fail(self, what: str) -> DataError:
        kind = f" ({self.kind} row)" if self.kind else ""
        return DataError(f"{self.src}: line {self.line}, column {self.column}{kind}: {what}")


def _number(text: str, at: _Cell, lo: float | None = None, hi: float | None = None, unit: str = "",
            lo_open: bool = False) -> float:
    """A cell's number: decimal ASCII digits, finite, within [lo, hi]
    (:func:`foldprint.core.schema.number_text`, which reports through ``at.fail``)."""
    return number_text(text, at, lo, hi, unit, lo_open)


def _name(text: str, at: _Cell) -> str:
    """A material name, by the library's rule (:func:`foldprint.core.schema.ident`): the
    fitted file names it as a TOML key that every command must load back."""
    return ident(text, at)  # the schema's words, the cell's location (at.fail)


#: The smallest and largest ``sigma`` of a row, per kind, in the row's unit: below, one row
#: outweighs every other by more than floating point resolves (5e-324 and 1e-300 made the
#: residuals infinite); above, the row says nothing (our choices: 1e-6 of the value's
#: scale; the whole range of the value).
SIGMA_RANGE = {"ratio": (1e-6, 1.5, ""), "angle": (1e-4, 225.0, "deg"), "time_to": (1e-4, 1e6, "s"),
               "spread": (1e-4, 1e6, "s"), "tg": (1e-4, 600.0, "deg C"), "fixity": (1e-6, 1.0, ""),
               **{k: (1e-4, 2.0, "(relative)") for k in DMA_KINDS}}


def _sigma(text: str, at: _Cell, kind: str) -> float:
    lo, hi, unit = SIGMA_RANGE[kind]
    v = _number(text, at, unit=unit)
    if not lo <= v <= hi:
        raise at.fail(f"must be in [{lo:g}, {hi:g}]{' ' + unit if unit else ''}, got {v:g} (a smaller sigma makes one "
                      "row outweigh the others beyond floating point, a larger one says the row tells nothing)")
    return v


def _header(row: list[str], src: str) -> list[str]:
    cols = [c.strip() for c in row]
    for i, c in enumerate(cols):
        if c not in COLUMNS:
            raise DataError(f"{src}: line 1, column {i + 1}: unknown column {c[:40]!r}; the columns are "
                            f"{', '.join(COLUMNS)} (docs/calibrate.md)")
        if cols.index(c) != i:
            raise DataError(f"{src}: line 1, column {i + 1}: column {c!r} appears twice")
    for need in ("kind", "material", "value"):
        if need not in cols:
            raise DataError(f"{src}: line 1: the header has no {need!r} column; the columns are "
                            f"{', '.join(COLUMNS)} (docs/calibrate.md)")
    return cols


def _dma_row(cells: dict[str, str], at: dict, line: int, kind: str, material: str, sigma: float | None,
             source: str) -> DmaRow:
    temp = _number(cells["temperature_c"], at["temperature_c"], *TEMPERATURE_C, "deg C")
    freq = (_number(cells["frequency_hz"], at["frequency_hz"], *FREQUENCY_HZ, "Hz", lo_open=True)
            if kind in DYNAMIC_KINDS else None)
    time_s = (_number(cells["time_s"], at["time_s"], *RELAXATION_S, "s", lo_open=True) if kind == "relaxation"
              else None)
    lo, hi, unit = DMA_VALUE[kind]
    value = _number(cells["value"], at["value"], lo, hi, unit, lo_open=True)
    return DmaRow(line, kind, material, temp, freq, time_s, value, sigma, source)


def _row(cells: dict[str, str], line: int, src: str) -> Observation | Property | DmaRow:
    kind = cells.get("kind", "")
    if kind not in KINDS:
        raise _Cell(src, line, "kind", "").fail(f"{kind[:40]!r} is not a kind; use one of {', '.join(KINDS)}")
    at = {c: _Cell(src, line, c, kind) for c in COLUMNS}
    for c in NEEDS[kind]:
        if not cells.get(c):
            raise at[c].fail(f"is blank; a {kind} row needs {', '.join(NEEDS[kind])}")
    for c, v in cells.items():
        if v and c != "kind" and c not in NEEDS[kind] and c not in MAY[kind]:
            raise at[c].fail(f"means nothing for a {kind} row (got {v[:40]!r}); leave it blank")
    material = _name(cells["material"], at["material"])
    if cells.get("reference"):
        _name(cells["reference"], at["reference"])
    sigma = _sigma(cells["sigma"], at["sigma"], kind) if cells.get("sigma") else None
    source = cells.get("source", "")
    if kind in DMA_KINDS:
        return _dma_row(cells, at, line, kind, material, sigma, source)
    if kind == "tg":
        return Property(line, kind, material, _number(cells["value"], at["value"], *TEMPERATURE_C, "deg C"),
                        sigma, source)
    if kind == "fixity":
        return Property(line, kind, material, _number(cells["value"], at["value"], 0.0, 1.0, lo_open=True),
                        sigma, source)
    bath = _number(cells["bath_c"], at["bath_c"], *TEMPERATURE_C, "deg C")
    thick = (_number(cells["thickness_mm"], at["thickness_mm"], MIN_LENGTH_MM, MAX_LENGTH_MM, "mm")
             if cells.get("thickness_mm") else DEFAULT_THICKNESS_MM)
    initial = (_number(cells["initial_c"], at["initial_c"], *TEMPERATURE_C, "deg C")
               if cells.get("initial_c") else DEFAULT_FIX_C)
    printed = (_number(cells["printed_deg"], at["printed_deg"], 0.0, 180.0, "deg", lo_open=True)
               if cells.get("printed_deg") else PAPER_PRINTED_DEG)
    if printed >= 180.0:
        raise at["printed_deg"].fail("must be below 180 deg (180 is flat: nothing to recover)")
    relation = cells.get("relation") or "about"
    if relation not in RELATIONS:
        raise at["relation"].fail(f"{relation[:40]!r} is not a relation; use one of {', '.join(RELATIONS)}")
    time_s = level = None
    if kind in CURVE_KINDS:
        time_s = _number(cells["time_s"], at["time_s"], 0.0, 1e6, "s")
        value = (_number(cells["value"], at["value"], -0.25, 1.25) if kind == "ratio" else
                 _number(cells["value"], at["value"], 0.0, 225.0, "deg"))  # noise near flat reads past 180
    else:
        level = _number(cells["level"], at["level"], 0.0, 1.0, lo_open=True)
        if level >= 1.0:
            raise at["level"].fail("must be below 1 (the model reaches R = 1 only in the limit)")
        value = (_number(cells["value"], at["value"], 0.0, 1e6, "s", lo_open=True) if kind == "time_to" else
                 _number(cells["value"], at["value"], -1e6, 1e6, "s"))
        if kind == "spread" and cells["reference"] == material:
            raise at["reference"].fail(f"is the row's own material {material!r}; a spread compares two materials")
    return Observation(line, kind, material, cells.get("reference") or None, bath, thick, initial, time_s, level,
                       value, relation, sigma, printed, source)


def _lines(text: str) -> list[str]:
    """The file's lines (``\\n`` or ``\\r\\n`` ends a line, nothing else: a form feed or
    U+2028 inside a cell stays there, to be refused), comment lines blank."""
    lines = text.split("\n")
    lines = [ln[:-1] if ln.endswith("\r") else ln for ln in lines]
    return [("" if ln.lstrip().startswith("#") else ln) for ln in lines]


def _cells(row: list[str], line: int, src: str, header: list[str] | None) -> None:
    """Refuse a row a CSV reader took from more than one line, or a cell holding a control
    character: a cell is one line of text (a line break inside quotes would be lost)."""
    for i, c in enumerate(row):
        bad = control_char(c)
        if bad is not None:
            col = f"column {header[i]}" if header and i < len(header) else f"cell {i + 1}"
            raise DataError(f"{src}: line {line}, {col}: holds the control character {bad!r}; a cell is "
                            "one line of text without tabs, form feeds or NULs")


def parse_hinge_data(text: str, src: str) -> HingeData:
    """Rows of ``text`` (the CSV layout above); :class:`DataError` naming the line and column
    of the first bad cell."""
    header: list[str] | None = None
    obs: list[Observation] = []
    props: list[Property] = []
    dma: list[DmaRow] = []
    reader = csv.reader(_lines(text), strict=True)
    line = 0
    try:
        for row in reader:
            if reader.line_num != line + 1:
                raise DataError(f"{src}: line {line + 1}: a quoted cell runs past the end of its line (to line "
                                f"{reader.line_num}); a cell is one line of text: close the quote (\"...\") on "
                                "the line it opens")
            line = reader.line_num
            _cells(row, line, src, header)
            if not any(c.strip() for c in row):
                continue
            if header is None:
                header = _header(row, src)
                continue
            if len(row) > len(header):
                raise DataError(f"{src}: line {line}: {len(row)} cells for {len(header)} columns (a comma too "
                                "many? quote a source that contains commas: \"...\")")
            if len(obs) + len(props) + len(dma) >= MAX_ROWS:
                raise DataError(f"{src}: more than {MAX_ROWS} rows; split the measurements into several runs")
            cells = {c: (row[i].strip() if i < len(row) else "") for i, c in enumerate(header)}
            item = _row(cells, line, src)
            (props if isinstance(item, Property) else dma if isinstance(item, DmaRow) else obs).append(item)
    except csv.Error as exc:
        what = ("a quoted cell is not closed (\"...\" needs its closing quote on the same line)"
                if "unexpected end" in str(exc) else f"not valid CSV: {exc}")
        raise DataError(f"{src}: line {line + 1 if 'unexpected end' in str(exc) else reader.line_num}: {what}") \
            from None
    if header is None:
        raise DataError(f"{src}: empty: expected a header line ({', '.join(COLUMNS)}) and rows (docs/calibrate.md)")
    if not obs and not dma:
        raise DataError(f"{src}: no ratio, angle, time_to or spread rows and no DMA rows (storage, loss, "
                        "tan_delta, relaxation): nothing to fit the model to")
    return HingeData(src, tuple(obs), tuple(props), tuple(dma))


def load_hinge_data(path: str | Path) -> HingeData:
    """The measurements of the CSV file at ``path``."""
    return parse_hinge_data(read_text(path, "a CSV file of hinge measurements (docs/calibrate.md)"), str(path))
