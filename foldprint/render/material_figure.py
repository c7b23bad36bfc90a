"""The figure of ``foldprint materials --plot-model``: each hinge material's viscoelastic model
as a DMA temperature sweep shows it (storage modulus E'(T) and tan delta(T) at 1 Hz) beside its
hinge's recovery ratio R(t) in the bath. It draws what it is handed
(:func:`foldprint.apps.catalog.model_curves`); it computes nothing."""

from __future__ import annotations

from typing import Mapping, Sequence

import numpy as np

from .figures import pyplot


def material_model_figure(curves: Sequence[Mapping], bath_c: float, freq_hz: float):
    """Three panels: E'(T) (log scale), tan delta(T) at ``freq_hz`` with each material's Tg
    marked, R(t) at ``bath_c``. Each item of ``curves`` has ``name``, ``color``, ``tg_c``,
    ``temperature_c``, ``storage_mpa``, ``tan_delta``, ``time_s`` and ``ratio`` (arrays)."""
    plt = pyplot()
    fig, (ax0, ax1, ax2) = plt.subplots(1, 3, figsize=(14, 4.2))
    for c in curves:
        T = np.asarray(c["temperature_c"], float)
        ax0.plot(T, c["storage_mpa"], color=c["color"], lw=1.5, label=c["name"])
        ax1.plot(T, c["tan_delta"], color=c["color"], lw=1.5, label=c["name"])
        ax1.axvline(c["tg_c"], color=c["color"], lw=0.8, ls=":")
        ax2.plot(c["time_s"], c["ratio"], color=c["color"], lw=1.5, label=c["name"])
    ax0.set_yscale("log")
    ax0.set_xlabel("temperature (°C)")
    ax0.set_ylabel("storage modulus E' (MPa)")
    ax0.set_title(f"E'(T) at {freq_hz:g} Hz")
    ax1.set_xlabel("temperature (°C)")
    ax1.set_ylabel("tan δ")
    ax1.set_title(f"tan δ(T) at {freq_hz:g} Hz (dotted: each material's Tg)")
    ax2.set_xlabel("time in the bath (s)")
    ax2.set_ylabel("recovery ratio R")
    ax2.set_xscale("log")
    ax2.set_ylim(0.0, 1.02)
    ax2.set_title(f"R(t), bath {bath_c:g} °C")
    for ax in (ax0, ax1, ax2):
        ax.grid(alpha=0.3)
    ax2.legend(fontsize=8, ncol=2, loc="upper left")
    fig.tight_layout()
    return fig
