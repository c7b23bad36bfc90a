"""What building the printed part costs (booleans and meshing grow with its features),
estimated from the design alone before any geometry is built, and refused through the
guard (:func:`foldprint.core.guards.enforce`) over the memory limit or the time budget."""

from __future__ import annotations

import math

from ..core.guards import BASE_BYTES, LIFT_TIME, enforce, fmt_bytes, fmt_seconds, lift_memory_env, source_of
from ..core.modes import Interface

#: export: seconds and bytes per geometric feature (panel outline points, hinge bend
#: slices per segment, teeth), measured with benchmarks/bench_scale.py (docs/input-safety.md)
EXPORT_S_PER_FEATURE = 1.5e-3
EXPORT_BYTES_PER_FEATURE = 8_000


def export_features(design) -> float:
    """Geometric features of the printed part, counted from the design alone (no
    geometry built): outline points of every panel, and per hinge its segments (slots)
    x its bend slices (5 deg each, plus the step edges of a stepped hinge) and teeth."""
    feats = 0.0
    for p in design.panels:
        feats += len(p.outline) + sum(len(h) for h in p.holes)
    for h in design.hinges:
        st = h.style
        length = float(h.length)
        segs = 1.0
        if st.max_segment_mm > 0 and length > st.max_segment_mm:
            segs = max(2.0, math.ceil((length + st.slot_width_mm) / (st.max_segment_mm + st.slot_width_mm)))
        slices = max(1.0, math.ceil(abs(float(h.angle)) / math.radians(5.0)))
        if st.stepped and st.step_period_mm > 0:
            slices += 2 * max(1.0, round(float(h.width) / st.step_period_mm))
        teeth = 2 * length / st.tooth_pitch_mm if st.interface == Interface.TRIANGULAR and st.tooth_pitch_mm > 0 else 0.0
        feats += segs * (slices + 2) + teeth
    return feats


def check_export(design) -> dict:
    """Refuse an export whose estimated time (booleans and meshing grow with the part's
    features) or memory exceeds the limits, before any geometry is built."""
    feats = export_features(design)
    est = {"features": feats, "seconds": feats * EXPORT_S_PER_FEATURE,
           "bytes": BASE_BYTES + feats * EXPORT_BYTES_PER_FEATURE}
    what = (f"{len(design.panels)} panels and {len(design.hinges)} hinges ({feats:.3g} features: outline "
            "points, hinge slices x segments, teeth)")
    return enforce(est, f"{source_of(design)}export",
                   (f"{what} need about {fmt_bytes(est['bytes'])}", f"split the design, or {lift_memory_env(est)}"),
                   (f"{what} take about {fmt_seconds(est['seconds'])} to build",
                    f"split the design, use a plain hinge style (fewer slices and teeth), or {LIFT_TIME}"))
