"""Figures (matplotlib, headless Agg backend). Functions return the Figure; the
``save_*`` helpers write PNGs through :func:`foldprint.core.files.write_atomic`."""

from __future__ import annotations

import io
from pathlib import Path
from typing import Sequence

import numpy as np

from ..core.display import seconds
from ..core.constants import DEFAULT_FIX_C, DEFAULT_THICKNESS_MM, PLOT_FORMATS
from ..core.errors import DataError
from ..model.materials import MaterialLibrary
from ..model.paper_statements import load_statements
from ..physics.recovery.curve import recovery_curve
from ..physics.recovery.table import fold_times


def _plt():
    import matplotlib

    matplotlib.use("Agg", force=True)
    import matplotlib.pyplot as plt

    return plt


def pyplot():
    """``matplotlib.pyplot`` on the headless Agg backend, for the other figure modules."""
    return _plt()


def figure_bytes(fig, fmt: str = "png", dpi: int = 110, *, crop: bool = True) -> bytes:
    """Render a figure to bytes (deterministic metadata) and close it. ``crop``: cut it to
    its drawing plus 0.1 in (``bbox_inches="tight"``, which draws the figure twice: once
    to measure it); False saves the figure as it is, for a figure whose layout already
    fits (``tight_layout``, the stills of :mod:`foldprint.render.stills`)."""
    buf = io.BytesIO()
    meta = {"Software": None} if fmt == "png" else {}
    fig.savefig(buf, format=fmt, dpi=dpi, metadata=meta, **({"bbox_inches": "tight"} if crop else {}))
    _plt().close(fig)
    return buf.getvalue()


def figure_format(path: str | Path, option: str = "--plot") -> str:
    """The format of a figure file, from the end of its name: one of
    :data:`~foldprint.core.constants.PLOT_FORMATS`, else :class:`DataError` naming them
    (called before anything is computed or written)."""
    fmt = Path(path).suffix.lstrip(".").lower()
    if fmt not in PLOT_FORMATS:
        raise DataError(f"{option} {str(path)[:80]!r}: the file name must end in "
                        f"{', '.join('.' + f for f in PLOT_FORMATS)} (the figure's format), got "
                        f"{('.' + fmt) if fmt else 'no suffix'!r}")
    return fmt


def save_figure(fig, path: str | Path, dpi: int = 110) -> Path:
    """Write ``fig`` to ``path`` whole (:func:`foldprint.core.files.write_atomic`), in the
    format its name ends in (:func:`figure_format`)."""
    from ..core.files import write_atomic

    try:
        fmt = figure_format(path)
    except DataError:
        import matplotlib.pyplot as plt

        plt.close(fig)
        raise
    return write_atomic(path, figure_bytes(fig, fmt, dpi))


def fold_time_chart(lib: MaterialLibrary, temperatures: Sequence[float], thickness_mm: float = DEFAULT_THICKNESS_MM,
                    initial_c: float = DEFAULT_FIX_C):
    """Fig. 1b style: 98 % fold time of every hinge material against bath temperature."""
    plt = _plt()
    fig, (ax0, ax1) = plt.subplots(1, 2, figsize=(10, 4))
    hinges = lib.hinges()
    temps = np.asarray(sorted(temperatures), float)
    dense = np.linspace(min(temps.min(), 70.0), max(temps.max(), 100.0), 16)
    for m in hinges:  # one vectorised, cached evaluation per material for the line and the marks
        ft = fold_times(m, np.concatenate([dense, temps]), thickness_mm, initial_c)
        y = np.array([np.nan if v is None else v for v in ft])
        ax1.plot(dense, y[:len(dense)], color=m.color, label=m.name, lw=1.5)
        ax1.plot(temps, y[len(dense):], "o", color=m.color, ms=4)
    ax1.set_xlabel("bath temperature (°C)")
    ax1.set_ylabel("fold time to 98 % recovery (s)")
    ax1.set_yscale("log")
    ax1.set_title("fold time (Fig. 1b style)")
    ax1.grid(alpha=0.3)
    ax1.legend(fontsize=8, ncol=2)
    ax0.bar([m.name for m in hinges], [m.tg_c for m in hinges], color=[m.color for m in hinges],
            edgecolor="k", lw=0.5)
    ax0.set_ylabel("Tg (°C)")
    ax0.set_title("glass transition (Fig. 1a style)")
    fig.tight_layout()
    return fig


def recovery_calibration_figure(lib: MaterialLibrary, thickness_mm: float = DEFAULT_THICKNESS_MM, initial_c: float = DEFAULT_FIX_C):
    """R(t) of every hinge material at 80, 90 and 100 C, with the paper's targets."""
    plt = _plt()
    fig, axes = plt.subplots(1, 4, figsize=(16, 3.8))
    t = np.linspace(0, 14, 701)
    for ax, bath in zip(axes[:3], (80.0, 90.0, 100.0)):
        for m in lib.hinges():
            c = recovery_curve(m, bath, thickness_mm, initial_c)
            ax.plot(t, c(t), color=m.color, label=m.name)
        ax.axhline(0.98, color="k", ls=":", lw=0.8)
        ax.set_title(f"bath {bath:g} °C")
        ax.set_xlabel("time (s)")
        ax.grid(alpha=0.3)
    axes[0].set_ylabel("recovery ratio R")
    axes[0].legend(fontsize=7)
    ax = axes[3]
    spreads = []
    baths = np.linspace(75, 100, 11)
    h = lib.hinges()
    for b in baths:
        f1 = recovery_curve(h[0], b, thickness_mm, initial_c).fold_time
        f7 = recovery_curve(h[-1], b, thickness_mm, initial_c).fold_time
        spreads.append(np.nan if f1 is None or f7 is None else f7 - f1)
    ax.plot(baths, spreads, "k-", label="model")
    st = load_statements()
    paper = [st[f"fig1b_spread_{b}"].value_s for b in (80, 100)]
    ax.errorbar([80, 100], paper, yerr=st.approx_tol_s, fmt="rs", capsize=4,
                label=f"paper (≈{paper[0]:g} s, ≈{paper[1]:g} s), ±{st.approx_tol_s:g} s: its '~'")
    ax.set_xlabel("bath temperature (°C)")
    ax.set_ylabel(f"{h[-1].name} − {h[0].name} fold time (s)")
    ax.set_title("spread of fold times")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7)
    fig.tight_layout()
    return fig


def plot_recovery_calibration(lib: MaterialLibrary, path: str | Path) -> Path:
    return save_figure(recovery_calibration_figure(lib), path)


def hinge_angle_figure(result):
    """Fig. 3b style: each hinge's fold angle (deg) against time, contacts marked."""
    plt = _plt()
    from ..model.materials import default_library

    lib = default_library()
    traj = result.trajectory
    fig, ax = plt.subplots(figsize=(7, 4))
    for k, h in enumerate(result.design.hinges):
        color = lib[h.material].color if h.material in lib else None
        ax.plot(traj.times, np.degrees(np.abs(traj.angles[:, k])), color=color, lw=1.4,
                label=f"{h.id} ({h.material})")
    for c in result.contacts:
        ax.axvline(c.time, color="r", ls="--", lw=0.8)
        ax.text(c.time, ax.get_ylim()[1] * 0.95, f" {c.panels[0]}–{c.panels[1]}", color="r", fontsize=7)
    ax.set_xlabel("time (s)")
    ax.set_ylabel("|fold angle| (deg)")
    ax.set_title(f"{result.design.name}: hinge angles at {traj.bath_c:g} °C ({traj.model} hinges)")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7, ncol=2, loc="lower right")
    fig.tight_layout()
    return fig


def collision_index_figure(result):
    """Fig. 4 style: the paper's collision index S_ij of every panel pair against time;
    contact is S_ij in the band (0, 1) outside the paper's exception cases."""
    plt = _plt()
    idx = result.index2d
    fig, ax = plt.subplots(figsize=(7, 4))
    ax.axhspan(0, 1, color="0.9", zorder=0)
    for k, (i, j) in enumerate(idx.pairs):
        if idx.adjacent[k]:
            continue
        ax.plot(idx.times, idx.s_ij[:, k], lw=0.6, color="0.4", alpha=0.7)
        hit = idx.contact[:, k]
        if hit.any():
            ax.plot(idx.times[hit], idx.s_ij[hit, k], ".", ms=3, color="r")
    ax.set_ylim(-3, 4)
    ax.set_xlabel("time (s)")
    ax.set_ylabel("collision index $S_{ij}$")
    ax.set_title(f"{result.design.name}: collision index of {int((~idx.adjacent).sum())} non-adjacent pairs")
    ax.grid(alpha=0.3)
    fig.tight_layout()
    return fig


def sample_outcomes_figure(robust, worst: int | None = None):
    """The Monte-Carlo samples of a jam-probability result (:class:`foldprint.simulation.robust.RobustResult`):
    left, when each sample ends (its fold time when it completes, its first contact when it
    collides) with the nominal fold marked; right, how often each panel pair is the first
    to collide. ``worst``: the index of a sample to mark (e.g. the one the viewer replays).
    No empty axes: without a colliding sample the right panel is left out, and when no
    sample (nor the nominal fold) completes or collides there is nothing to draw: None."""
    plt = _plt()
    outs = robust.outcomes
    nominal = robust.nominal
    done = np.array([o.fold_time for o in outs if o.fold_time is not None], float)
    hit = np.array([o.time for o in outs if o.time is not None], float)
    both = np.concatenate([done, hit, [t for t in (nominal.fold_time,) if t is not None]])
    pairs = robust.collisions()
    if not both.size and nominal.first_collision is None:
        return None
    if pairs:
        fig, (ax0, ax1) = plt.subplots(1, 2, figsize=(10, 3.6), gridspec_kw={"width_ratios": [3, 2]})
    else:
        fig, ax0 = plt.subplots(1, 1, figsize=(6.4, 3.6))
    if both.size:
        lo, hi = float(both.min()), float(both.max())
        pad = max(0.05 * (hi - lo), 0.02)
        bins = np.linspace(lo - pad, hi + pad, 21)
        if done.size:
            ax0.hist(done, bins=bins, color="#2ca02c", alpha=0.75, label=f"fold time, {done.size} that complete")
        if hit.size:
            ax0.hist(hit, bins=bins, color="#d62728", alpha=0.75, label=f"first contact, {hit.size} that collide")
    c = nominal.first_collision
    if nominal.fold_time is not None:
        ax0.axvline(nominal.fold_time, color="k", ls="--", lw=1, label=f"nominal fold time {seconds(nominal.fold_time)}")
    elif c is not None:
        ax0.axvline(c.time, color="k", ls="--", lw=1, label=f"nominal contact {seconds(c.time)}")
    if worst is not None:
        o = outs[worst]
        t = o.time if o.time is not None else o.fold_time
        if t is not None:
            ax0.axvline(t, color="#9467bd", ls=":", lw=1.5, label=f"worst sample (#{worst}) {seconds(t)}")
    other = sum(o.jammed and o.time is None for o in outs)
    ax0.set_xlabel("time (s)")
    ax0.set_ylabel("samples")
    ax0.yaxis.get_major_locator().set_params(integer=True)
    ax0.set_title(f"{robust.samples} samples, seed {robust.seed}" +
                  (f" ({other} jam without a collision)" if other else ""), fontsize=10)
    ax0.grid(alpha=0.3)
    if ax0.get_legend_handles_labels()[0]:
        ax0.legend(fontsize=7, loc="upper left")
    if pairs:
        labels = [f"{a}\u2013{b}" for (a, b), _ in pairs][::-1]
        counts = [k for _, k in pairs][::-1]
        ax1.barh(labels, counts, color="#d62728", alpha=0.8)
        ax1.set_xlabel("samples")
        ax1.xaxis.get_major_locator().set_params(integer=True)
        ax1.set_title("first-colliding panel pairs", fontsize=10)
        ax1.grid(alpha=0.3, axis="x")
    from ..checks.report import percent

    fig.suptitle(f"{robust.design}: jam probability {percent(robust.jam_probability)} under scatter "
                 f"({robust.hinge_model.value} hinges)", fontsize=11)
    fig.tight_layout()
    return fig
