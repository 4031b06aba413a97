"""The report's figures (matplotlib, Agg): per element PMR and coherence, the matrix overview, the time plot.

Each function returns PNG bytes; :mod:`pmr_ros.report.html` embeds them in the
page and writes them beside it.  matplotlib is imported when a figure is
drawn (the ``data`` extra).
"""

from __future__ import annotations

import io
from typing import Any

import numpy as np

from ..core.pmr.curves import ElementCurves
from ..core.results import Diagnosis, ElementDiagnosis
from ..data import PlantData
from ..data.clean import runs

__all__ = ["COLOURS", "decimate", "element_figure", "matrix_figure", "time_figure"]

COLOURS = {"ok": "#2e7d32", "mismatch": "#c62828", "inconclusive": "#f9a825", "none": "#bdbdbd"}
"""Verdict colours: green, red, amber; grey for an element the model does not have."""

EXCLUDED_COLOURS = {"missing": "#9e9e9e", "frozen": "#42a5f5", "controller off": "#ff8a65", "mode unknown": "#757575"}
MANUAL_COLOUR = "#ffd54f"
"""An MV in manual (kept: open loop for it)."""
"""Shading of excluded samples in the time plot, by reason."""

MAX_POINTS = 4000
"""Longest line drawn in the time plot; longer signals are drawn as a min/max envelope per bucket."""


def _pyplot() -> Any:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def done_layout(fig: Any) -> None:
    """Say the figure's layout is done (``tight_layout``): ``savefig`` then draws it once, not twice.

    ``tight_layout()`` leaves a placeholder layout engine behind, and ``savefig`` first draws a figure that has a
    layout engine without painting it (to lay it out), then draws it again to paint it.  Without an engine it only
    paints it: the same PNG, byte for byte, for about a third less time.
    """
    fig.set_layout_engine(None)  # no engine (``"none"`` would leave the placeholder)


def _png(fig: Any) -> bytes:
    """The figure as PNG, its layout done (``tight_layout``) before."""
    buffer = io.BytesIO()
    done_layout(fig)
    fig.savefig(buffer, format="png", dpi=100)
    _pyplot().close(fig)
    return buffer.getvalue()


def element_figure(curves: ElementCurves, element: ElementDiagnosis) -> bytes:
    """Magnitude, phase and coherence of one element's PMR against frequency, as PNG.

    The spectral estimate with its confidence band, the fitted parametric
    curve, the "no mismatch" line (1, 0 deg), the informative band shaded.
    """
    plt = _pyplot()
    fig, axes = plt.subplots(3, 1, figsize=(7.0, 6.4), sharex=True, height_ratios=[3, 2, 1.4])
    w = curves.omega[1:]
    band_end = float(curves.omega[curves.band].max())
    for ax in axes:
        ax.axvspan(w[0], band_end, color="#e3f2fd", zorder=0, label="informative band")
        ax.grid(True, which="both", alpha=0.3)
    magnitude, phase = _draw_ratio(axes, curves, w <= band_end)
    axes[2].plot(w, curves.coherence[1:], color="#455a64", lw=1.2)
    _limits(axes, magnitude, phase, w, band_end)
    axes[0].set_ylabel("|G / Ĝ|")
    axes[1].set_ylabel("phase [deg]")
    axes[2].set_ylabel("coherence")
    axes[2].set_xlabel("frequency [rad/sample]")
    axes[0].legend(fontsize=8, loc="best", ncol=2)
    fig.suptitle(f"{element.name}: {element.verdict}", color=COLOURS[element.verdict], fontsize=13, fontweight="bold")
    fig.tight_layout()
    return _png(fig)


def _draw_ratio(axes: Any, curves: ElementCurves, inside: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Estimate (grey beyond the informative band), its band, "no mismatch" and the fitted curve; |est|, phase."""
    w, est, radius = curves.omega[1:], curves.estimate[1:], curves.radius[1:]
    magnitude = np.abs(est)
    phase = np.degrees(np.unwrap(np.angle(est)))
    half = np.degrees(np.arcsin(np.clip(radius / np.maximum(magnitude, 1e-300), 0.0, 1.0)))
    level = f"{100 * curves.level:.0f} % band"
    axes[0].fill_between(
        w, np.maximum(magnitude - radius, 0.0), magnitude + radius, where=inside, color="#90caf9", label=level
    )
    axes[1].fill_between(w, phase - half, phase + half, where=inside, color="#90caf9")
    for ax, values, label in ((axes[0], magnitude, "spectral estimate"), (axes[1], phase, None)):
        ax.plot(w, np.where(inside, values, np.nan), color="#1565c0", lw=1.2, label=label)
        ax.plot(w, np.where(inside, np.nan, values), color="#bdbdbd", lw=0.8,
                label="beyond the band (noise)" if label else None)  # fmt: skip
    axes[0].axhline(1.0, color="black", ls=":", lw=1.2, label="no mismatch")
    axes[1].axhline(0.0, color="black", ls=":", lw=1.2)
    if curves.fitted is not None:
        fitted = curves.fitted[1:]
        axes[0].plot(w, np.abs(fitted), color="#c62828", ls="--", lw=1.6, label="fitted ratio (model scaled)")
        axes[1].plot(w, np.degrees(np.unwrap(np.angle(fitted))), color="#c62828", ls="--", lw=1.6)
    return magnitude, phase


def _limits(axes: Any, magnitude: np.ndarray, phase: np.ndarray, w: np.ndarray, band_end: float) -> None:
    """Log frequency axis; magnitude and phase scaled to the informative band (noise beyond it would swamp it)."""
    inside = w <= band_end
    axes[2].set_xscale("log")
    axes[2].set_xlim(w[0], w[-1])
    axes[2].set_ylim(0.0, 1.02)
    top = float(np.nanmax(magnitude[inside])) if inside.any() else 2.0
    axes[0].set_ylim(0.0, max(1.3, 1.25 * top))
    span = phase[inside] if inside.any() else phase
    axes[1].set_ylim(min(-30.0, float(span.min()) - 20.0), max(30.0, float(span.max()) + 20.0))


def _cell_text(element: ElementDiagnosis) -> str:
    p = element.parametric if element.method == "parametric" else None
    if p is not None and p.gain_mismatch_pct is not None:
        lines = [f"ΔK {p.gain_mismatch_pct:+.1f} %"]
        if p.tau_mismatch_pct is not None:
            lines.append(f"Δτ {p.tau_mismatch_pct:+.1f} %")
        if p.delay_mismatch_samples is not None:
            lines.append(f"ΔD {p.delay_mismatch_samples:+d}")
        return "\n".join(lines)
    c = element.classic if element.method == "classic" else None
    if c is not None:
        return f"K/K̂ {c.gain_ratio:.2f}\nτ idx {c.tau_index:+.0f}\nΔD {c.delay_mismatch_samples:+d}"
    return "no estimate"


def matrix_figure(diagnosis: Diagnosis, output_names: tuple[str, ...], input_names: tuple[str, ...]) -> bytes:
    """The controller at a glance: one cell per element, coloured by verdict, with its numbers, as PNG."""
    plt = _pyplot()
    n_out, n_in = len(output_names), len(input_names)
    size = max(1.1, min(2.0, 12.0 / max(n_out, n_in)))
    fig, ax = plt.subplots(figsize=(1.8 + size * n_in, 0.9 + size * n_out))
    for element in diagnosis:
        empty = element.model.kind == "none"
        colour = COLOURS["none" if empty else element.verdict]
        ax.add_patch(plt.Rectangle((element.column, element.row), 0.96, 0.96, color=colour))
        label = element.name if empty else f"{element.name}\n{_cell_text(element)}"
        ax.text(element.column + 0.48, element.row + 0.48, label, ha="center", va="center", fontsize=9, color="white")
    ax.set_xlim(0, n_in)
    ax.set_ylim(n_out, 0)
    ax.set_xticks(np.arange(n_in) + 0.48, input_names, rotation=30, ha="right")
    ax.set_yticks(np.arange(n_out) + 0.48, output_names)
    ax.tick_params(length=0)
    for side in ax.spines.values():
        side.set_visible(False)
    handles = [plt.Rectangle((0, 0), 1, 1, color=c) for c in COLOURS.values()]
    ax.legend(handles, ["ok", "mismatch", "inconclusive", "no model"], loc="upper left", bbox_to_anchor=(1.01, 1.0))
    ax.set_title("verdict per element (rows: CVs, columns: MVs)")
    fig.tight_layout()
    return _png(fig)


def decimate(x: np.ndarray, values: np.ndarray, points: int = MAX_POINTS) -> tuple[np.ndarray, np.ndarray]:
    """A long signal as the min/max envelope of ``points // 2`` buckets (NaN kept as gaps); short ones as they are."""
    if x.size <= points:
        return x, values
    buckets = points // 2
    edges = np.linspace(0, x.size, buckets + 1).astype(int)
    xs, ys = [], []
    for a, b in zip(edges[:-1], edges[1:], strict=True):
        chunk = values[a:b]
        finite = chunk[np.isfinite(chunk)]
        low, high = (finite.min(), finite.max()) if finite.size else (np.nan, np.nan)
        xs += [x[a], x[b - 1]]
        ys += [low, high]
    return np.array(xs), np.array(ys)


def time_figure(data: PlantData, output_names: tuple[str, ...], input_names: tuple[str, ...]) -> bytes:
    """The time plot as PNG: r and y per output, u per input, excluded samples shaded by reason."""
    plt = _pyplot()
    rows = len(output_names) + len(input_names)
    fig, axes = plt.subplots(rows, 1, figsize=(10.0, 1.5 + 1.35 * rows), sharex=True, squeeze=False)
    hours = data.time_s / 3600.0
    for j, name in enumerate(output_names):
        ax = axes[j, 0]
        if data.columns["r"][j]:  # a zone CV without a setpoint column: no r drawn
            # the setpoint distinct from the measurement: orange, dashed, drawn over it
            ax.plot(*decimate(hours, data.signals["r"][:, j]), color="#e65100", lw=1.1, ls="--", label="r (setpoint)",
                    zorder=3)  # fmt: skip
        ax.plot(*decimate(hours, data.signals["y"][:, j]), color="#1565c0", lw=0.6, label="y")
        ax.set_ylabel(name, rotation=0, ha="right")
    for k, name in enumerate(input_names):
        ax = axes[len(output_names) + k, 0]
        ax.plot(*decimate(hours, data.signals["u"][:, k]), color="#6a1b9a", lw=0.6, label="u")
        for a, b in runs(data.limited[:, k]):
            ax.axvspan(hours[a], hours[b - 1], color="#ab47bc", alpha=0.35, lw=0)
        for a, b in runs(data.manual[:, k]) if data.manual is not None else ():
            ax.axvspan(hours[a], hours[b - 1], color=MANUAL_COLOUR, alpha=0.35, lw=0)
        ax.set_ylabel(name, rotation=0, ha="right")
    for ax in axes[:, 0]:
        _shade_excluded(ax, data, hours)
        ax.grid(True, alpha=0.3)
    handles = [plt.Rectangle((0, 0), 1, 1, color=c, alpha=0.5) for c in EXCLUDED_COLOURS.values()]
    labels = [f"excluded: {reason}" for reason in EXCLUDED_COLOURS]
    handles.append(plt.Rectangle((0, 0), 1, 1, color="#ab47bc", alpha=0.35))
    labels.append("MV at a limit (kept)")
    handles.append(plt.Rectangle((0, 0), 1, 1, color=MANUAL_COLOUR, alpha=0.35))
    labels.append("MV in manual (kept)")
    lines = axes[0, 0].get_lines()
    axes[0, 0].legend(
        [*lines, *handles],
        [*(line.get_label() for line in lines), *labels],
        fontsize=7,
        ncol=6,
        loc="lower left",
        bbox_to_anchor=(0.0, 1.02),
    )
    axes[-1, 0].set_xlabel(f"hours since {data.start}")
    fig.tight_layout()
    return _png(fig)


def _shade_excluded(ax: Any, data: PlantData, hours: np.ndarray) -> None:
    for reason, mask in data.excluded.items():
        for a, b in runs(mask):
            ax.axvspan(
                hours[a], hours[min(b, hours.size - 1)], color=EXCLUDED_COLOURS.get(reason, "#9e9e9e"), alpha=0.45, lw=0
            )
