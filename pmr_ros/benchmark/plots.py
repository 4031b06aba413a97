"""The benchmark report's figures as PNG bytes: detection and coverage against record length, ROC, CPU time.

matplotlib is imported here only (Agg backend), when a figure is drawn.
"""

from __future__ import annotations

import io
from typing import TYPE_CHECKING, Any

import numpy as np

from .scoring import roc_points

if TYPE_CHECKING:
    import pandas as pd  # annotations only: pandas is the data extra, imported where used

__all__ = ["length_figure", "roc_figure"]


def _pyplot() -> Any:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _png(fig: Any) -> bytes:
    buffer = io.BytesIO()
    fig.savefig(buffer, format="png", dpi=100, bbox_inches="tight")
    _pyplot().close(fig)
    return buffer.getvalue()


def _cases(scores: pd.DataFrame) -> list[tuple[str, int]]:
    return sorted({(str(u), int(d)) for u, d in zip(scores["unit"], scores["disturbance"], strict=True)})


def _grid(plt: Any, cases: list[tuple[str, int]], height: float) -> tuple[Any, list[Any]]:
    """A figure of one row per unit, one column per disturbance of ``cases``: (fig, the cases' axes in order)."""
    units = sorted({u for u, _ in cases}) or [""]
    columns = sorted({d for _, d in cases}) or [0]
    fig, axes = plt.subplots(len(units), len(columns), figsize=(4.2 * len(columns), height * len(units)), squeeze=False)
    used = [axes[units.index(u)][columns.index(d)] for u, d in cases]
    for ax in axes.ravel():
        if all(ax is not a for a in used):
            ax.set_visible(False)
    return fig, used


def length_figure(scores: pd.DataFrame, column: str, label: str, *, log: bool = False) -> bytes:
    """``column`` of the score table against record length, one line per method, a panel per unit and disturbance."""
    plt = _pyplot()
    cases = _cases(scores)
    fig, used = _grid(plt, cases, 3.4)
    for ax, (unit, disturbance) in zip(used, cases, strict=True):
        part = scores[(scores["unit"] == unit) & (scores["disturbance"] == disturbance)]
        for method, lines in part.groupby("method", sort=False):
            lines = lines.sort_values("samples")
            ax.plot(lines["samples"], lines[column], marker="o", label=str(method))
        ax.set_xscale("log", base=2)
        if log:
            ax.set_yscale("log")
        ax.set_title(f"{unit}, {'coloured disturbance' if disturbance else 'white noise'}", fontsize=9)
        ax.set_xlabel("record length [samples]")
        ax.set_ylabel(label)
        ax.grid(True, alpha=0.3)
    used[-1].legend(fontsize=7)
    fig.tight_layout()
    return _png(fig)


def roc_figure(labelled: pd.DataFrame, *, samples: int) -> bytes:
    """ROC of each method with a score, at ``samples``, one panel per unit and disturbance (pooled over runs)."""
    plt = _pyplot()
    part = labelled[labelled["samples"] == samples]
    cases = _cases(part)
    fig, used = _grid(plt, cases, 3.6)
    for ax, (unit, disturbance) in zip(used, cases, strict=True):
        case = part[(part["unit"] == unit) & (part["disturbance"] == disturbance)]
        for method, lines in case.groupby("method", sort=False):
            if not np.isfinite(lines["evidence"]).any():
                continue
            fa, det = roc_points(lines["evidence"].to_numpy(), lines["mismatched"].to_numpy())
            ax.step(fa, det, where="post", label=str(method))
        ax.plot([0, 1], [0, 1], color="0.7", lw=0.8)
        ax.axvline(0.01, color="0.5", ls=":", lw=0.8)
        ax.set_xscale("symlog", linthresh=0.01)
        ax.set_xlim(0, 1)
        ax.set_title(f"{unit}, {'coloured' if disturbance else 'white'}, {samples} samples", fontsize=9)
        ax.set_xlabel("false-alarm rate")
        ax.set_ylabel("detection rate")
        ax.grid(True, alpha=0.3)
    if used:
        used[-1].legend(fontsize=7)
    fig.tight_layout()
    return _png(fig)
