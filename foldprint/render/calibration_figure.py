"""The figure of a calibration (``foldprint calibrate --plot``): the measurements beside the
fitted model. Left: every measured curve (``ratio`` / ``angle`` rows) as points with the
model's curve through them; right: every ``time_to`` / ``spread`` row as its measured value
with its uncertainty (or the side an inequality allows) and the model's value."""

from __future__ import annotations

from ..physics.calibration.fit import Fit, Problem
from .figures import pyplot


def _curve_panel(ax, problem: Problem, fit: Fit, curves: dict) -> None:
    groups: dict = {}
    for k, o in enumerate(problem.data.observations):
        if o.kind in ("ratio", "angle"):
            groups.setdefault(o.curve, []).append(k)
    colors = pyplot().rcParams["axes.prop_cycle"].by_key()["color"]
    t = problem.t
    for n, (key, ks) in enumerate(groups.items()):
        o = problem.data.observations[ks[0]]
        c = colors[n % len(colors)]
        r = curves[(o.material, o.bath_c, o.thickness_mm, o.initial_c)]
        y = r if o.kind == "ratio" else \
            180.0 - (180.0 - o.printed_deg) * (1.0 - problem.fixity[o.material] * (1.0 - r))
        tmax = max(problem.data.observations[k].time_s for k in ks) * 1.2 or problem.horizon
        m = t <= tmax
        ax.plot(t[m], y[m], color=c, lw=1.2)
        ax.errorbar([problem.data.observations[k].time_s for k in ks],
                    [problem.data.observations[k].value for k in ks],
                    yerr=[problem.sigmas[k] for k in ks], fmt="o", ms=3, color=c, lw=0.8,
                    label=f"{o.material} {o.bath_c:g} °C {o.thickness_mm:g} mm ({o.kind})")
    ax.set_xlabel("time in the bath (s)")
    ax.set_ylabel("recovery ratio R / angle (deg)")
    ax.set_title("measured curves (points) and the fitted model")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7)


def _time_panel(ax, problem: Problem, fit: Fit) -> None:
    rows = [(k, o) for k, o in enumerate(problem.data.observations) if o.kind in ("time_to", "spread")]
    for y, (k, o) in enumerate(rows):
        s = problem.sigmas[k]
        lo = s if o.relation != "at_least" else 0.0
        hi = s if o.relation != "at_most" else 0.0
        ax.errorbar([o.value], [y], xerr=[[lo], [hi]], fmt="s", color="k", ms=5, capsize=3)
        if o.relation != "about":
            ax.annotate("", xy=(o.value + (2 * s if o.relation == "at_least" else -2 * s), y), xytext=(o.value, y),
                        arrowprops=dict(arrowstyle="->", color="k", lw=0.8))
        ax.plot([fit.predictions[k]], [y], "o", color="tab:red", ms=6)
    labels = [f"line {o.line}: {o.material}{'−' + o.reference if o.reference else ''} {o.bath_c:g} °C, "
              f"{o.level:.0%}" for _, o in rows]
    ax.set_yticks(range(len(rows)), labels, fontsize=7)
    ax.set_xlabel("time (s): measured ± sigma (black), model (red)")
    ax.set_title("times and spreads")
    ax.grid(alpha=0.3, axis="x")
    ax.invert_yaxis()


def _dma_panel(ax, d) -> None:
    """One material's DMA rows against its fitted model: E', E'' (MPa) and tan delta over
    temperature per frequency, or E(t) over time per temperature."""
    import numpy as np

    pb, ve = d.problem, d.problem.model(d.fit.x)
    dyn = [r for r in pb.rows if r.kind != "relaxation"]
    marks = {"storage": ("o", "tab:blue", "E'"), "loss": ("s", "tab:red", "E''"), "tan_delta": ("^", "tab:green",
                                                                                           "tan delta")}
    if dyn:
        for f in sorted({r.frequency_hz for r in dyn}):
            ts = np.linspace(min(r.temperature_c for r in dyn), max(r.temperature_c for r in dyn), 200)
            e1, e2 = ve.dynamic_mpa(f, ts)
            for kind, y in (("storage", e1), ("loss", e2), ("tan_delta", e2 / e1)):
                rows = [r for r in dyn if r.kind == kind and r.frequency_hz == f]
                if rows:
                    m, c, lab = marks[kind]
                    ax.plot([r.temperature_c for r in rows], [r.value for r in rows], m, ms=3, color=c,
                            label=f"{lab} {f:g} Hz")
                    ax.plot(ts, y, "-", color=c, lw=0.9)
        ax.set_xlabel("temperature (C)")
        ax.axvline(d.material.tg_c, color="0.5", lw=0.8, ls="--")
    else:
        for temp in sorted({r.temperature_c for r in pb.rows}):
            rows = [r for r in pb.rows if r.temperature_c == temp]
            t = np.geomspace(min(r.time_s for r in rows), max(r.time_s for r in rows), 200)
            line, = ax.plot(t, ve.relaxation_mpa(t, temp), "-", lw=0.9)
            ax.plot([r.time_s for r in rows], [r.value for r in rows], "o", ms=3, color=line.get_color(),
                    label=f"E(t) {temp:g} C")
        ax.set_xscale("log")
        ax.set_xlabel("time (s)")
    ax.set_yscale("log")
    ax.set_title(f"{pb.material}: DMA, Tg {d.material.tg_c:.1f} C (1 Hz tan-delta peak), chi2 {d.fit.chi2:.3g}",
                 fontsize=8)
    ax.legend(fontsize=6)


def calibration_figure(problem: Problem | None, fit: Fit | None, dma=()):
    """Measurements against the model at ``fit``'s optimum, and each DMA fit's rows against
    its viscoelastic model."""
    plt = pyplot()
    kinds = {o.kind for o in problem.data.observations} if problem is not None else set()
    panels = [p for p, ks in (("curves", {"ratio", "angle"}), ("times", {"time_to", "spread"})) if kinds & ks]
    panels += list(dma)
    fig, axes = plt.subplots(1, len(panels), figsize=(6.5 * len(panels), 4.2), squeeze=False)
    curves = problem.curves(fit.x) if problem is not None else {}
    for ax, p in zip(axes[0], panels):
        if p == "curves":
            _curve_panel(ax, problem, fit, curves)
        elif p == "times":
            _time_panel(ax, problem, fit)
        else:
            _dma_panel(ax, p)
    src = problem.data.source if problem is not None else dma[0].problem.source
    what = f" (chi2 {fit.chi2:.3g}, {fit.dof} dof)" if fit is not None else ""
    fig.suptitle(f"foldprint calibrate: {src}{what}", fontsize=9)
    fig.tight_layout()
    return fig
