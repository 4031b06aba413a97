"""The sweep's figures in the manner of the paper's Figs. 2-7: one quantity of every element against nu.

matplotlib is imported here only (Agg backend), so the core and the sweep
itself run without it.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from ..config import PmrConfig
from ..core.sim.model import SCENARIOS
from ..outputs import replacing
from ..sweep.analysis import (
    PointSummary,
)
from .sweep_paper import PAPER_FIGURES, PARAMETRIC_QUANTITY, QUANTITY, SCENARIO_LABELS, by, paper_breakdown

if TYPE_CHECKING:
    from collections.abc import Sequence

    from matplotlib.axes import Axes
    from matplotlib.figure import Figure
    from matplotlib.typing import ColorType
    from numpy.typing import ArrayLike


def _tau_axis(ax: Axes, points: list[PointSummary], element: str) -> None:
    """Linear while the indices stay small, symmetric-log once they explode (at large nu)."""
    from matplotlib.ticker import FixedLocator, FuncFormatter

    values = [abs(v) for p in points if p.element == element for v in (p.tau_low, p.tau_high) if np.isfinite(v)]
    if not values or max(values) <= 200:
        return
    ax.set_yscale("symlog", linthresh=50)
    top = 10 ** np.ceil(np.log10(max(values)))
    ticks = [0.0] + [s * 10.0**e for e in range(2, int(np.log10(top)) + 1) for s in (-1, 1)] + [-50.0, 50.0]
    ax.yaxis.set_major_locator(FixedLocator(sorted(ticks)))
    ax.yaxis.set_major_formatter(FuncFormatter(lambda v, _: f"{v:g}"))


def plot_sweep(
    summary: list[PointSummary],
    *,
    method: str,
    element_swept: str,
    quantity: str,
    path: Path,
    tau_threshold: float,
    grid: list[list[str]],
    paper: bool,
) -> Path:
    """One figure: ``quantity`` of every element versus nu, one line per scenario.

    Lines are medians over seeds, bands span the smallest to the largest seed.

    Parameters
    ----------
    summary : list of PointSummary
        Every point of the sweep (all methods and sweeps; this one is picked out).
    method, element_swept, quantity : str
        The diagnosis method, the swept element and ``gain``, ``tau`` or ``delay``.
    path : Path
        The PNG to write.
    tau_threshold : float
        The classic time-constant flag threshold [-], drawn on classic tau figures.
    grid : list of list of str
        Element names by output (rows of the figure) and input (columns).
    paper : bool
        Mark the paper's breakdown nu and figure number (:func:`paper_comparison_applies`).

    Returns
    -------
    Path
        ``path``.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    points = by(summary, method=method, element_swept=element_swept)
    axis_labels = PARAMETRIC_QUANTITY if method == "parametric" else QUANTITY
    fig, axes = plt.subplots(len(grid), len(grid[0]), figsize=(10, 7.2), sharex=True, squeeze=False)
    panel = _Panel(method, element_swept, quantity, axis_labels[quantity][1], paper_breakdown(element_swept, paper))
    for j, element in enumerate(name for row in grid for name in row):
        row, column = divmod(j, len(grid[0]))
        _draw_panel(
            axes[row][column],
            points,
            panel,
            element=element,
            place=(row, column, len(grid)),
            tau_threshold=tau_threshold,
        )
    title = _figure_title(
        method=method, element_swept=element_swept, quantity=quantity, name=axis_labels[quantity][0], paper=paper
    )
    return _save(fig, axes, title, path)


def _save(fig: Figure, axes: Any, title: str, path: Path) -> Path:
    """The legend (from the first panel) and the title, then the PNG at ``path``."""
    import matplotlib.pyplot as plt

    handles, labels = axes[0][0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="lower center", ncol=5, fontsize=8, frameon=False)
    fig.suptitle(title, fontsize=9)
    fig.tight_layout(rect=(0, 0.04, 1, 1))
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.set_layout_engine(None)  # the layout is done: savefig draws the figure once (figures.done_layout)
    with replacing(path) as tmp:
        fig.savefig(tmp, dpi=90, format=path.suffix.lstrip(".") or "png")
    plt.close(fig)
    return path


@dataclass(frozen=True)
class _Panel:
    """What every panel of one figure shares: the method, the swept element, the quantity and its axis label."""

    method: str
    element_swept: str
    quantity: str
    y_label: str
    paper_nu: float | None


def _draw_panel(
    ax: Axes,
    points: list[PointSummary],
    panel: _Panel,
    *,
    element: str,
    place: tuple[int, int, int],
    tau_threshold: float,
) -> None:
    """One element's panel: the scenarios' lines, the axis scale and the decoration."""
    import matplotlib

    method, quantity = panel.method, panel.quantity
    colors = matplotlib.color_sequences["tab10"]
    _plot_scenarios(ax, by(points, element=element), method=method, quantity=quantity, colors=colors)
    _scale_quantity_axis(ax, points, method=method, quantity=quantity, element=element, tau_threshold=tau_threshold)
    _decorate_panel(
        ax,
        points,
        element=element,
        element_swept=panel.element_swept,
        place=place,
        y_label=panel.y_label,
        paper_nu=panel.paper_nu,
    )


def _plot_scenarios(
    ax: Axes, points: list[PointSummary], *, method: str, quantity: str, colors: Sequence[ColorType]
) -> None:
    """One panel's lines: per scenario the median over seeds, the min-max band and the injected value."""
    step = quantity == "delay"  # delays are whole samples: draw steps, not slopes
    for s, scenario in enumerate(SCENARIOS):
        series = sorted(by(points, scenario=scenario), key=lambda p: p.nu)
        if not series:
            continue
        x = np.array([p.nu for p in series])
        med, low, high = (
            np.array([getattr(p, f"{quantity}_{part}") for p in series]) for part in ("median", "low", "high")
        )
        color = colors[s]
        ax.plot(
            x, med, color=color, lw=1.4, label=SCENARIO_LABELS[scenario], drawstyle="steps-mid" if step else "default"
        )
        ax.fill_between(x, low, high, color=color, alpha=0.15, lw=0, step="mid" if step else None)
        truth = _injected(series[0], method=method, quantity=quantity)
        if truth is not None:
            ax.axhline(truth, color=color, lw=0.8, ls="--", alpha=0.7)


def _injected(point: PointSummary, *, method: str, quantity: str) -> float | None:
    """The injected value of ``quantity`` on the figure's axis; None for the classic tau index (no true index)."""
    if quantity == "tau":
        return point.true_time_constant_pct if method == "parametric" else None
    return point.true_gain_ratio if quantity == "gain" else point.true_delay_samples


def _scale_quantity_axis(
    ax: Axes, points: list[PointSummary], *, method: str, quantity: str, element: str, tau_threshold: float
) -> None:
    """Clip the gain and fitted-tau axes to a readable range; classic tau: symlog and the flag thresholds."""
    if quantity == "tau" and method == "parametric":
        lo, hi = ax.get_ylim()
        ax.set_ylim(max(lo, -60.0), min(hi, 60.0))
    elif quantity == "tau":
        _tau_axis(ax, points, element)
        for sign in (-1, 1):
            ax.axhline(sign * tau_threshold, color="0.5", lw=0.6, ls=":")
    if quantity == "gain":
        lo, hi = ax.get_ylim()
        ax.set_ylim(max(lo, 0.5), min(hi, 1.5))


def element_grid(config: PmrConfig) -> list[list[str]]:
    """Element names by output row and input column."""
    names, n_in = config.model.element_names(), config.model.n_inputs
    return [names[i * n_in : (i + 1) * n_in] for i in range(config.model.n_outputs)]


def _decorate_panel(
    ax: Axes,
    points: list[PointSummary],
    *,
    element: str,
    element_swept: str,
    place: tuple[int, int, int],
    y_label: str,
    paper_nu: float | None,
) -> None:
    """Title, grid, axis labels on the outer panels, the paper's breakdown nu (if any) and the top row-ratio axis.

    ``place`` is the panel's row and column and the figure's number of rows.
    """
    row, column, n_rows = place
    bottom, left, top = row == n_rows - 1, column == 0, row == 0
    if paper_nu is not None:
        ax.axvline(paper_nu, color="0.3", lw=0.8, ls=":")
    ax.set_title(element + ("  (swept)" if element == element_swept else ""), fontsize=10)
    ax.grid(True, lw=0.3, alpha=0.5)
    if bottom:
        ax.set_xlabel("ν")
    if left:
        ax.set_ylabel(y_label, fontsize=8)
    if top:
        _ratio_axis(ax, points)


def _ratio_axis(ax: Axes, points: list[PointSummary]) -> None:
    """A top axis in the row time-constant ratio, which is linear in nu."""
    ratio_of = {p.nu: p.row_time_constant_ratio for p in points}
    nus = sorted(ratio_of)
    if len(nus) < 2:
        return
    slope = (ratio_of[nus[-1]] - ratio_of[nus[0]]) / (nus[-1] - nus[0])
    offset = ratio_of[nus[0]] - slope * nus[0]

    # matplotlib passes arrays; asanyarray only gives the arithmetic a type (subclasses kept)
    def to_ratio(nu: ArrayLike) -> np.ndarray:
        return slope * np.asanyarray(nu) + offset

    def to_nu(ratio: ArrayLike) -> np.ndarray:
        return (np.asanyarray(ratio) - offset) / slope

    top = ax.secondary_xaxis("top", functions=(to_ratio, to_nu))
    top.set_xlabel("row time-constant ratio", fontsize=8)


def _figure_title(*, method: str, element_swept: str, quantity: str, name: str, paper: bool) -> str:
    """The figure's title: what is drawn, and the paper's figure it corresponds to (if the paper applies)."""
    title = f"{name.capitalize()} diagnosis, τ of {element_swept} × ν ({method}); median and min-max over seeds"
    figure = PAPER_FIGURES.get((element_swept, quantity)) if paper else None
    if figure:
        title += f" — cf. paper's Fig. {figure}"
    title += "\ndashed: injected value"
    return title + (
        "; dotted vertical: the paper's breakdown ν" if paper_breakdown(element_swept, paper) is not None else ""
    )
