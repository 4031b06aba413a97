"""The report's figure of a plant that differs in shape: its estimated frequency response against the best scaled model.

When the best scaled model ``rho Ghat(s alpha) e^{-dD s}`` does not fit the
data beyond noise, the element is inconclusive with
:data:`~pmr_ros.core.pmr.parametric.shape.SHAPE_REASON` (issue 23, item 4);
this Bode plot shows why: the plant's estimated frequency response
(:attr:`~pmr_ros.core.pmr.curves.ElementCurves.plant_estimate`, the spectral
PMR times the model's own response, with its confidence band scaled the same
way) against the best scaled model's
(:attr:`~pmr_ros.core.pmr.curves.ElementCurves.plant_fitted`) and the model's
as given.  A shape the scaling cannot take (a second resonance, a lag the
model lacks) shows as a magnitude slope or a phase bend no scaled curve follows.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..core.pmr.curves import ElementCurves
from ..core.pmr.parametric.shape import SHAPE_REASON
from ..core.results import ElementDiagnosis
from .figures import COLOURS, _png, _pyplot

__all__ = ["differs_in_shape", "plant_phase", "shape_figure"]


def differs_in_shape(element: ElementDiagnosis) -> bool:
    """Whether the element's reasons name :data:`~pmr_ros.core.pmr.parametric.shape.SHAPE_REASON`."""
    return any(SHAPE_REASON in reason for reason in element.all_reasons)


def plant_phase(response: np.ndarray, reference: np.ndarray) -> np.ndarray:
    """The phase of ``response`` [deg], unwrapped along the smooth ``reference`` (a noisy estimate's own unwrap jumps).

    Each value is the reference's unwrapped phase plus the wrapped angle of ``response / reference``.

    Examples
    --------
    >>> w = np.linspace(0.1, 3.0, 5)
    >>> np.round(plant_phase(np.exp(-4j * w), np.exp(-4j * w)), 1).tolist()
    [-22.9, -189.1, -355.2, -521.4, -687.5]
    """
    unwrapped = np.unwrap(np.angle(reference))
    return np.degrees(unwrapped + np.angle(response / reference))


def shape_figure(curves: ElementCurves, element: ElementDiagnosis) -> bytes | None:
    """Magnitude and phase of the plant's estimated frequency response against the best scaled model, as PNG.

    Parameters
    ----------
    curves : ElementCurves
        The element's curves with the model's own response (:attr:`~ElementCurves.model_response`).
    element : ElementDiagnosis
        Its name and verdict for the title.

    Returns
    -------
    bytes or None
        None without the model's response (then there is no plant to draw).
    """
    plant = curves.plant_estimate
    if plant is None or curves.model_response is None:
        return None
    plt = _pyplot()
    fig, axes = plt.subplots(2, 1, figsize=(7.0, 5.0), sharex=True, height_ratios=[3, 2])
    w = curves.omega[1:]
    inside = curves.band[1:]
    band_end = float(curves.omega[curves.band].max())
    for ax in axes:
        ax.axvspan(w[0], max(band_end, w[0]), color="#e3f2fd", zorder=0, label="informative band")
        ax.grid(True, which="both", alpha=0.3)
    reference = curves.plant_fitted if curves.plant_fitted is not None else curves.model_response
    _draw_estimate(axes, curves, curves.model_response, inside, reference[1:])
    _draw_models(axes, curves, curves.model_response, reference[1:])
    _limits(axes, curves, np.abs(plant[1:][inside]), w)
    axes[0].set_ylabel("|G| (plant's gain per frequency)")
    axes[1].set_ylabel("phase [deg]")
    axes[1].set_xlabel("frequency [rad/sample]")
    axes[0].legend(fontsize=8, loc="lower left", ncol=2)
    title = f"{element.name}: {element.verdict}" + (" (differs in shape)" if differs_in_shape(element) else "")
    fig.suptitle(title, color=COLOURS[element.verdict], fontsize=12, fontweight="bold")
    fig.tight_layout()
    return _png(fig)


def _draw_estimate(
    axes: Any, curves: ElementCurves, model_response: np.ndarray, inside: np.ndarray, reference: np.ndarray
) -> None:
    """The plant's estimate as points (grey beyond the informative band) with its band, the PMR's scaled by |Ghat|."""
    w, plant = curves.omega[1:], (curves.estimate * model_response)[1:]
    magnitude = np.abs(plant)
    radius = curves.radius[1:] * np.abs(model_response[1:])
    phase = plant_phase(plant, reference)
    half = np.degrees(np.arcsin(np.clip(radius / np.maximum(magnitude, 1e-300), 0.0, 1.0)))
    level = f"{100 * curves.level:.0f} % band"
    axes[0].fill_between(w, np.maximum(magnitude - radius, 0.0), magnitude + radius, where=inside, color="#90caf9",
                         label=level)  # fmt: skip
    axes[1].fill_between(w, phase - half, phase + half, where=inside, color="#90caf9")
    for ax, values, label in ((axes[0], magnitude, "estimated plant"), (axes[1], phase, None)):
        ax.plot(w[inside], values[inside], ".", color="#1565c0", ms=3.5, label=label)
        ax.plot(w[~inside], values[~inside], ".", color="#bdbdbd", ms=2.5,
                label="beyond the band (noise)" if label else None)  # fmt: skip


def _draw_models(axes: Any, curves: ElementCurves, model_response: np.ndarray, reference: np.ndarray) -> None:
    """The best scaled model (red line) and the model as given (black, dashed)."""
    w = curves.omega[1:]
    fitted = curves.plant_fitted
    if fitted is not None:
        axes[0].plot(w, np.abs(fitted[1:]), color="#c62828", lw=1.6, label="best scaled model")
        axes[1].plot(w, plant_phase(fitted[1:], reference), color="#c62828", lw=1.6)
    model = model_response[1:]
    axes[0].plot(w, np.abs(model), color="black", ls="--", lw=1.2, label="model as given")
    axes[1].plot(w, plant_phase(model, reference), color="black", ls="--", lw=1.2)


def _limits(axes: Any, curves: ElementCurves, in_band: np.ndarray, w: np.ndarray) -> None:
    """Log-log magnitude scaled to the models and the estimate in the band ``in_band`` (noise beyond would swamp it)."""
    axes[1].set_xscale("log")
    axes[1].set_xlim(w[0], w[-1])
    shown = [in_band]
    if curves.model_response is not None:
        shown.append(np.abs(curves.model_response[1:]))
    if curves.plant_fitted is not None:
        shown.append(np.abs(curves.plant_fitted[1:]))
    values = np.concatenate(shown)
    values = values[np.isfinite(values) & (values > 0)]
    axes[0].set_yscale("log")
    if values.size:
        low, high = float(values.min()), float(values.max())
        axes[0].set_ylim(max(low / 2.0, high * 1e-4), high * 2.0)
