"""``foldprint calibrate``: hinge measurements in, a materials file out, with what the data
can and cannot say. Chains the reader (:mod:`foldprint.io.hinge_data`), the fit
(:mod:`foldprint.physics.calibration.fit`), its uncertainty and findings
(:mod:`foldprint.physics.calibration.profile`), the writer
(:mod:`foldprint.exchange.materials_file`) and the figure
(:mod:`foldprint.render.calibration_figure`). ``docs/calibrate.md`` explains the output.
"""

from __future__ import annotations

import hashlib
import logging
import tomllib
from dataclasses import dataclass
from pathlib import Path

from ..core.version import __version__
from ..core.errors import DataError, FoldprintError
from ..core.schema import control_char
from ..core.files import write_atomic
from ..exchange.materials_file import materials_toml
from ..io.hinge_data import HingeData, load_hinge_data, read_text
from ..model.materials import MaterialLibrary, parse_library
from ..physics.calibration.fit import FITTABLE, Fit, Hold, Problem, fit_best, held_value, holds
from ..physics.calibration.profile import Interval, curve_residuals, findings, profile, row_reading
from ..physics.calibration.fit_cost import check_dma_fits, check_fit
from ..physics.calibration.dma import DMA_LOCKED, DmaFit, dma_json, dma_problems, fit_dma
from .calibrate_library import changes, entries

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class Calibration:
    """One calibration: the recovery problem (None when the file has DMA rows only), its
    optimum, the intervals (empty without the profile), per-curve residuals, findings, the
    starting library's chi2 on the data, the parameters held (not fitted) with their
    sources, and the DMA fit of every material with DMA rows (:mod:`..physics.calibration.dma`)."""

    problem: Problem | None
    fit: Fit | None
    intervals: tuple[Interval, ...]
    curves: list
    findings: list
    start_chi2: float
    holds: tuple[Hold, ...] = ()
    dma: tuple[DmaFit, ...] = ()
    library: MaterialLibrary | None = None
    source: str = ""

    def held_values(self) -> dict[str, tuple[float, str]]:
        """{name: (value, source)} of every held parameter (the library's value where a
        ``--fix NAME`` gave none); the materials a DMA measured keep their own shift and
        spectrum."""
        pb = self.problem
        own = [m for m in pb.materials if not pb.locked.get(m)] if pb is not None else []
        if not own:  # no material whose parameters the holds apply to (DMA-measured ones keep their own)
            return {}
        rec = pb.base[own[0]].recovery
        return {h.name: (getattr(rec, h.name) if h.value is None else h.value, h.source) for h in self.holds}

    @property
    def joint_threshold(self) -> float:
        """Delta chi2 of the joint confidence region of all free parameters."""
        from scipy.stats import chi2

        return float(chi2.ppf(self.problem.config.confidence, len(self.fit.x))) * self.fit.scale


def parse_fixed(items) -> dict:
    """``--fix NAME`` (hold at the library's value: returned as None) or ``NAME=VALUE``."""
    out = {}
    for item in items or ():
        name, _, value = item.partition("=")
        name = name.strip()
        if name not in FITTABLE:
            raise DataError(f"--fix {item!r}: {name!r} is not a recovery parameter calibrate fits; use one of "
                            f"{', '.join(FITTABLE)}")
        if value:
            out[name] = held_value(name, value)
        else:
            out[name] = None
    return out


def parse_fit(items) -> tuple[str, ...]:
    """``--fit NAME``: fit a parameter ``data/calibration.toml`` holds by default."""
    for name in items or ():
        if name not in FITTABLE:
            raise DataError(f"--fit {name!r}: not a recovery parameter calibrate fits; use one of {', '.join(FITTABLE)}")
    return tuple(items or ())


def calibrate(data: HingeData, library: MaterialLibrary, fixed: dict | None = None, per_material=(),
              with_profile: bool = True, fit_names=()) -> Calibration:
    """Fit ``data`` starting from ``library``; ``fixed`` {name: value or None (the
    library's)}; the parameters ``data/calibration.toml`` holds are held too unless named
    in ``fit_names``; ``per_material`` parameters fitted once per material."""
    held_by = holds(fixed, fit_names)
    names = {h.name for h in held_by}
    free = tuple(n for n in FITTABLE if n not in names)
    held = {h.name: h.value for h in held_by if h.value is not None}
    dma_pbs = dma_problems(data, library, {k: v for k, v in (fixed or {}).items() if v is not None},
                           "spectrum_span_decades" in fit_names)
    if dma_pbs:  # the DMA fits first (seconds): the recovery fit starts from what they fix
        check_dma_fits(dma_pbs, dma_pbs[0].config.starts, with_profile)
    dma = tuple(fit_dma(pb, library, with_profile) for pb in dma_pbs)
    for d in dma:
        log.info("DMA fit of %s: chi2 %.3f, Tg %.2f C", d.problem.material, d.fit.chi2, d.material.tg_c)
    tg_notes = [{"code": "tg_row", "material": d.problem.material, "message":
                 f"{d.problem.material}: its tg row ({data.tg(d.problem.material):g} C) is not fitted: the DMA's 1 Hz "
                 f"tan-delta peak, {d.material.tg_c:.2f} C, is its Tg"} for d in dma
                if data.tg(d.problem.material) is not None]
    if not data.observations:
        return Calibration(None, None, (), [], [fd for d in dma for fd in d.findings] + tg_notes, 0.0, held_by, dma,
                           library, data.source)
    problem = Problem(data, library, free=free, per_material=tuple(per_material), fixed=held,
                      measured={d.problem.material: d.material for d in dma}, locked=DMA_LOCKED)
    check_fit(problem, problem.config.starts, with_profile)  # refuse before the first curve is made
    r0 = problem.residuals(problem.library_point())
    result = fit_best(problem)
    log.info("fit: chi2 %.3f after %d evaluations (%s)", result.chi2, result.nfev, result.message)
    intervals = profile(problem, result) if with_profile else ()
    found = findings(problem, result, intervals) + [fd for d in dma for fd in d.findings] + tg_notes
    return Calibration(problem, result, intervals, curve_residuals(problem, result), found, float(r0 @ r0),
                       held_by, dma, library, data.source)


def header(cal: Calibration, data_path: str | Path, command: str) -> list[str]:
    digest = hashlib.sha256(read_text(data_path, "the measurements").encode("utf-8")).hexdigest()[:16]
    f, pb = cal.fit, cal.problem
    lines = [f"foldprint materials file, written by `{command}` (foldprint {__version__}).",
             f"Data: {data_path} (sha256 {digest}...), "
             f"{len(pb.data.observations) if pb else 0} recovery rows and "
             f"{sum(len(d.problem.rows) for d in cal.dma)} DMA rows fitted."]
    if f is not None:
        lines.append(f"Fit: scipy.optimize.least_squares (best of {max(1, len(f.ends))} starts), chi2 {f.chi2:.4g} for "
                     f"{f.dof} degrees of freedom, {f.rank} of {len(f.x)} parameter combinations fixed by the data; "
                     f"the library it started from: chi2 {cal.start_chi2:.4g}.")
    for d in cal.dma:
        lines.append(f"DMA fit of {d.problem.material}: chi2 {d.fit.chi2:.4g} for {d.fit.dof} degrees of freedom; "
                     f"tg_c {d.material.tg_c:.2f} C is the model's 1 Hz tan-delta peak and the shift's reference "
                     f"temperature (the data's largest 1 Hz tan delta: "
                     + ("none" if d.data_peak_c is None else f"{d.data_peak_c:g} C") + ").")
    lines.append("Load it with: foldprint <command> --materials THIS_FILE (docs/calibrate.md).")
    for name, (v, source) in cal.held_values().items():
        lines.append(f"Held, not fitted: {name} = {v:g} ({source}).")
    for fd in cal.findings:
        lines.append("NOTE: " + fd["message"])
    return [_plain(ln) for ln in lines]


def _plain(text: str) -> str:
    """``text`` for a comment line: control characters (a file name may hold them) as U+FFFD."""
    return "".join("\ufffd" if control_char(c) else c for c in text)


def check_outputs(out: str | Path | None = None, plot: str | Path | None = None) -> None:
    """Refuse, before the fit runs or anything is written, a ``--plot`` whose name does not
    end in a figure format we write (:func:`foldprint.render.figures.figure_format`), and
    ``--out`` and ``--plot`` naming one file."""
    if plot is not None:
        from ..render.figures import figure_format

        figure_format(plot)
    if out is not None and plot is not None and Path(out).absolute() == Path(plot).absolute():
        raise DataError(f"--out and --plot name the same file {str(out)[:80]!r}; give each its own")


def write(cal: Calibration, out: str | Path, data_path: str | Path, command: str) -> Path:
    """Write the materials file; its text is loaded back first (the library's parser, the
    names' rule), so a file no command could read is never written."""
    text = materials_toml(entries(cal), header(cal, data_path, command))
    try:
        parse_library(tomllib.loads(text), str(out), cal.library)
    except (ValueError, FoldprintError) as exc:  # a bug of the writer: say so, write nothing
        raise RuntimeError(f"the materials file for {out} would not load back: {exc}") from None
    return write_atomic(out, text)


def plot(cal: Calibration, path: str | Path) -> Path:
    from ..render.calibration_figure import calibration_figure
    from ..render.figures import figure_format, save_figure

    figure_format(path)
    return save_figure(calibration_figure(cal.problem, cal.fit, cal.dma), path)


def to_json(cal: Calibration) -> dict:
    """What ``foldprint calibrate --json`` prints (docs/calibrate.md lists the keys)."""
    pb, f = cal.problem, cal.fit
    dma = [dma_json(d) for d in cal.dma]
    if pb is None:
        return {"data": cal.source, "materials": [d.problem.material for d in cal.dma], "parameters": [],
                "fixed": {}, "held": [], "fit": None, "uncertainty": "profile" if any(d.intervals for d in cal.dma)
                else "none", "confidence": cal.dma[0].problem.config.confidence, "start": None, "curves": [],
                "rows": [], "findings": cal.findings, "fixity": {}, "changes": changes(cal), "dma": dma}
    ivs = {iv.label: iv for iv in cal.intervals}
    params = []
    for p, v, x0 in zip(pb.params, f.x, pb.library_point()):
        b = pb.config.bounds[p.name]
        iv = ivs.get(p.label)
        params.append({"name": p.name, "material": p.material, "value": float(v), "unit": b.unit,
                       "start": float(x0), "low": iv.low if iv else None, "high": iv.high if iv else None,
                       "identified": iv.identified if iv else None,
                       "identified_why": iv.why if iv else None, "at_bound": iv.at_bound if iv else None,
                       "bounds": [b.lower, b.upper], "bound_kind": b.kind, "bound_source": b.source})
    rows = [{"line": o.line, "kind": o.kind, "material": o.material, "reference": o.reference, "bath_c": o.bath_c,
             "thickness_mm": o.thickness_mm, "time_s": o.time_s, "level": o.level, "relation": o.relation,
             "measured": o.value, "model": float(m), "sigma": float(s), "residual_sigma": float(r),
             **_reading(o, float(m), float(s))}
            for o, m, s, r in zip(pb.data.observations, f.predictions, pb.sigmas, f.residuals)]
    delta = cal.start_chi2 - f.chi2
    names = list(dict.fromkeys(pb.materials + [d.problem.material for d in cal.dma]))
    return {"data": pb.data.source, "materials": names,
            "parameters": params,
            "fixed": {k: float(v) for k, v in pb.fixed.items()},
            "held": [{"name": k, "value": float(v), "source": s} for k, (v, s) in cal.held_values().items()],
            "fit": {"chi2": f.chi2, "dof": f.dof, "rank": f.rank, "scale": f.scale, "evaluations": f.nfev,
                    "start_ends": [float(c) for c in f.ends],
                    "converged": f.success, "message": f.message},
            "uncertainty": "profile" if cal.intervals else "none", "confidence": pb.config.confidence,
            "start": {"chi2": cal.start_chi2, "delta_chi2": delta, "joint_threshold": cal.joint_threshold,
                      "inside_joint_region": bool(delta <= cal.joint_threshold)},
            "curves": cal.curves, "rows": rows, "findings": cal.findings,
            "fixity": {m: float(x) for m, x in pb.fixity.items()}, "changes": changes(cal), "dma": dma}


def _reading(o, model: float, sigma: float) -> dict:
    """A time row's verdict under the one reading of the paper's words (its sigma as the
    tolerance): ``reading`` (words and interval) and ``verdict``; None for other rows."""
    rd = row_reading(o, sigma)
    return {"reading": None if rd is None else rd.text, "verdict": None if rd is None else rd.verdict(model)}


def run(data_path: str | Path, library: MaterialLibrary, fixed: dict | None = None, per_material=(),
        with_profile: bool = True, fit_names=()) -> Calibration:
    """:func:`calibrate` on the CSV file at ``data_path``."""
    return calibrate(load_hinge_data(data_path), library, fixed, per_material, with_profile, fit_names)
