"""What ``foldprint calibrate --out`` writes, and what it changes in the library.

A calibration adds each measured material with its own fitted parameters; every other
material of the library stays as it is (shared parameters fitted across the measured
materials apply to them only: the data say nothing about the grades they did not measure).
:func:`entries` gives the file's materials, :func:`changes` what the file adds and moves
(per material, each parameter from what to what), :func:`own_color` the display colour of
a material the file adds (deterministic from its name, apart from the library's).
"""

from __future__ import annotations

import colorsys
import hashlib
from dataclasses import fields, replace

from ..core.display import LIST_FIRST
from ..exchange.materials_file import Entry
from ..model.materials import Material, MaterialLibrary
from ..physics.calibration.fit import fitted_materials

#: Two colours closer than this (largest channel difference, 0..255) count as the same
#: (our choice: about what tells two swatches apart on a screen).
MIN_COLOR_STEP = 48


def _rgb(color: str) -> tuple[int, int, int]:
    h = color.lstrip("#")
    return int(h[0:2], 16), int(h[2:4], 16), int(h[4:6], 16)


def own_color(name: str, taken=()) -> str:
    """A display colour for a material the library does not have: a hue drawn from the
    sha256 of ``name`` (the same name, the same colour), stepped on by the golden angle
    until it is at least :data:`MIN_COLOR_STEP` from every colour in ``taken``."""
    used = [_rgb(c) for c in taken]
    hue = int.from_bytes(hashlib.sha256(name.encode("utf-8")).digest()[:4], "big") / 2 ** 32
    best, best_gap = None, -1
    for k in range(64):
        r, g, b = (round(255 * c) for c in colorsys.hsv_to_rgb((hue + 0.381966 * k) % 1.0, 0.55 + 0.1 * (k % 3), 0.8))
        gap = min((max(abs(r - u[0]), abs(g - u[1]), abs(b - u[2])) for u in used), default=255)
        if gap >= MIN_COLOR_STEP:
            return f"#{r:02x}{g:02x}{b:02x}"
        if gap > best_gap:
            best, best_gap = f"#{r:02x}{g:02x}{b:02x}", gap
    return best


def _measured(cal, library: MaterialLibrary) -> dict[str, Material]:
    """Each measured material as the file holds it: fitted parameters, measured Tg and
    fixity; one the library lacks gets its own colour and is not called a blend."""
    pb = cal.problem
    taken = [m.color for m in library.materials]
    out = {}
    fitted = {d.problem.material: d.material for d in cal.dma}
    if pb is not None:
        fitted.update(fitted_materials(pb, cal.fit.x))
    for name, mat in fitted.items():
        if name not in library:
            mat = replace(mat, color=own_color(name, taken), blend=False,
                          description="fitted by foldprint calibrate (not known to be a VeroWhite/TangoBlack blend)")
            taken.append(mat.color)
        out[name] = mat
    return out


def entries(cal) -> list[Entry]:
    """The materials the file holds: every measured one (fitted parameters, measured Tg and
    fixity), then every other hinge material of the library unchanged (its own recovery
    parameters written out, so the file does not depend on the library it is loaded over)."""
    pb, library = cal.problem, cal.library
    labels = {iv.label: iv for iv in cal.intervals}
    dma = {d.problem.material: d for d in cal.dma}
    measured = _measured(cal, library)
    out = []
    for name, mat in measured.items():
        rows = sum(name in (o.material, o.reference) for o in pb.data.observations) if pb else 0
        notes = [f"{name}: fitted to {rows} recovery rows" + (f" and {len(dma[name].problem.rows)} DMA rows"
                                                              if name in dma else "")]
        tg = pb.data.tg(name) if pb else None
        if name in dma:
            notes += _dma_notes(dma[name])
        else:
            notes.append("tg_c: " + ("measured, " + pb.data.property_source("tg", name) if tg is not None
                                     else "the library"))
        if name not in library:
            notes.append("blend = false: the data do not say it is a VeroWhite/TangoBlack digital material")
        for p, v in zip(pb.params if pb else (), cal.fit.x if pb else ()):
            if p.material in (None, name) and p.name not in pb.locked.get(name, ()):
                iv = labels.get(p.label)
                rng = f" [{iv.low:.4g}, {iv.high:.4g}] ({pb.config.confidence:.0%}, identified: {iv.identified})" \
                    if iv else ""
                notes.append(f"{p.name} = {v:.6g}{rng}")
        new = name not in library.names()  # a VW... composition is synthesised, not an entry
        out.append(Entry(mat, new, tg is not None or new or name in dma, tuple(notes)))
    for mat in library.hinges():
        if mat.name in measured or mat.recovery is None:
            continue
        out.append(Entry(mat, False, False, (f"{mat.name}: not measured; the library's values, unchanged",)))
    return out


def _dma_notes(d) -> list[str]:
    """Comment lines of a material a DMA measured: what its Tg means, each fitted parameter
    with its interval, and what the recovery model keeps from the library."""
    ivs = {iv.label: iv for iv in d.intervals}
    conf = d.problem.config.confidence
    lines = [f"tg_c: the model's tan-delta peak at 1 Hz (the paper's Tg), which is also the reference temperature "
             f"of its shift; fitted to the DMA rows (model peak {d.model_peak_c:.2f} C; the data's largest 1 Hz tan "
             "delta at " + ("no row" if d.data_peak_c is None else f"{d.data_peak_c:g} C") + ")"]
    for p, v in zip(d.problem.params, d.fit.x):
        iv = ivs.get(p.label)
        rng = f" [{iv.low:.4g}, {iv.high:.4g}] ({conf:.0%}, identified: {iv.identified})" if iv else ""
        lines.append(f"{p.name} = {v:.6g}{rng} (DMA)")
    for k, v in d.problem.held.items():
        lines.append(f"{k} = {v:g}: held in the DMA fit")
    lines.append(f"log10_tau_ref_s = {d.material.recovery.log10_tau_ref_s:.6g}: the spectrum's centre that puts the "
                 "1 Hz tan-delta peak at tg_c")
    return lines


def _params(mat: Material) -> dict[str, float]:
    out = {"tg_c": mat.tg_c, "fixity": mat.shape_fixity}
    out.update({k: getattr(mat, k) for k in ("glassy_mpa", "rubbery_mpa") if getattr(mat, k) is not None})
    if mat.recovery is not None:
        out.update({f.name: float(getattr(mat.recovery, f.name)) for f in fields(mat.recovery)})
    return out


def changes(cal) -> list[dict]:
    """What the file adds to and changes in the library it was fitted from: per measured
    material, ``status`` ("added" or "changed"), and ``moved``: each parameter whose value
    differs, ``{name, before (None: added), after}``. Materials not measured are unchanged
    (:func:`entries`) and not listed."""
    lib = cal.library
    out = []
    for name, mat in _measured(cal, lib).items():
        after = _params(mat)
        if name in lib:
            before = _params(lib[name])
            moved = [{"name": k, "before": before.get(k), "after": v} for k, v in after.items()
                     if k not in before or abs(v - before[k]) > 1e-9 * max(1.0, abs(before[k]))]
            out.append({"material": name, "status": "changed", "moved": moved})
        else:
            out.append({"material": name, "status": "added", "color": mat.color,
                        "moved": [{"name": k, "before": None, "after": v} for k, v in after.items()]})
    return out


def change_lines(items: list[dict]) -> list[str]:
    """:func:`changes` in words, one line per material, the first
    :data:`~foldprint.core.display.LIST_FIRST` of them and then a count of the rest (every
    material is in ``--json`` and the written file)."""
    lines = []
    for c in items:
        if c["status"] == "added":
            vals = ", ".join(f"{m['name']} {m['after']:.4g}" for m in c["moved"])
            lines.append(f"added {c['material']} (colour {c['color']}; not a VeroWhite/TangoBlack blend): {vals}")
        elif c["moved"]:
            vals = ", ".join(f"{m['name']} " + ("(none)" if m["before"] is None else f"{m['before']:.4g}")
                             + f" -> {m['after']:.4g}" for m in c["moved"])
            lines.append(f"changed {c['material']}: {vals}")
        else:
            lines.append(f"{c['material']}: measured, no parameter moved")
    if len(lines) > LIST_FIRST:
        rest = len(lines) - LIST_FIRST
        lines = lines[:LIST_FIRST] + [f"... and {rest} more material(s): each in --json and the written file"]
    return lines
