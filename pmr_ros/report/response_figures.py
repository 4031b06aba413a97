"""The report's time-domain figures: per element the step response of model and estimated plant, per CV the prediction.

The plots control engineers read beside the PMR's Bode plot.  The step
response of the estimated plant is the model's element scaled by the
estimate (``rho G(s alpha) exp(-dD s)``, :meth:`~pmr_ros.core.sim.lti.Element.scaled`);
its band is the envelope of the responses at the ends of the gain and
time-constant intervals (each at the configured confidence, so the band is
a per-parameter one, not a joint region).  The prediction figure runs the
measured inputs of the longest clean stretch through the model and through
the corrected model (:func:`~pmr_ros.core.loop.update.corrected_model`) and
draws them with the measured output and the model's residual.
"""

from __future__ import annotations

import itertools

import numpy as np

from ..core.records import Record
from ..core.results import ElementDiagnosis
from ..core.sim.lti import Element
from ..core.sim.model import TransferMatrix
from .figures import _png, _pyplot

__all__ = ["PREDICTION_SAMPLES", "plant_steps", "prediction_figure", "predictions", "step_figure"]

PREDICTION_SAMPLES = 720
"""Samples of the prediction figure: the end of the longest stretch (its start is the filters' settling)."""


def plant_steps(element: ElementDiagnosis, model: Element, n: int) -> tuple[np.ndarray, np.ndarray] | None:
    """The estimated plant's unit-step response and its band (the interval ends' envelope), shape (n,) and (2, n).

    None without a parametric estimate of the gain.
    """
    p = element.parametric
    if p is None or p.gain_mismatch_pct is None or p.delay_mismatch_samples is None:
        return None
    dd = int(p.delay_mismatch_samples)
    tau = (p.tau_mismatch_pct or 0.0, p.tau_mismatch_pct_interval or (p.tau_mismatch_pct or 0.0,) * 2)
    gain = (p.gain_mismatch_pct, p.gain_mismatch_pct_interval or (p.gain_mismatch_pct,) * 2)

    def response(gain_pct: float, tau_pct: float) -> np.ndarray:
        scaled = model.scaled(gain_ratio=1 + gain_pct / 100, time_scale=1 + tau_pct / 100, delay_change=dd)
        return np.concatenate(([0.0], scaled.step_response(n - 1)))

    corners = [response(g, t) for g, t in itertools.product(gain[1], tau[1])]
    return response(gain[0], tau[0]), np.array([np.min(corners, axis=0), np.max(corners, axis=0)])


def step_figure(element: ElementDiagnosis, model: Element, *, labels: dict[str, str], level: float) -> bytes | None:
    """The model's and the estimated plant's response to a unit step of the input, with the band, as PNG.

    Parameters
    ----------
    element : ElementDiagnosis
    model : Element
        The model's element (sample time, delay and dynamics).
    labels : dict
        ``time`` (the time unit) and ``gain`` (the gain's unit) for the axes; "" when not given.
    level : float
        The intervals' confidence [0..1], named in the legend.

    Returns
    -------
    bytes or None
        None without an estimate (then there is nothing to compare).
    """
    p = element.parametric
    shift = abs(int(p.delay_mismatch_samples or 0)) if p is not None else 0
    n = int(1.3 * max(model.settle_samples(), 10)) + 3 * shift  # the plant's response settles in view too
    found = plant_steps(element, model, n)
    if found is None:
        return None
    plant, band = found
    t = np.arange(n) * model.sample_time
    plt = _pyplot()
    fig, ax = plt.subplots(figsize=(7.0, 3.0))
    ax.fill_between(t, band[0], band[1], step="post", color="#c62828", alpha=0.2, lw=0,
                    label=f"estimated plant, {100 * level:.0f} % intervals")  # fmt: skip
    ax.step(t, np.concatenate(([0.0], model.step_response(n - 1))), where="post", color="black", ls="--",
            lw=1.2, label="model")  # fmt: skip
    ax.step(t, plant, where="post", color="#c62828", lw=1.4, label="estimated plant")
    ax.set_xlabel(f"time [{labels['time']}]" if labels["time"] else "time [model time unit]")
    ax.set_ylabel(f"response to a unit step [{labels['gain']}]" if labels["gain"] else "response to a unit step")
    ax.set_title(f"{element.name}: step response", fontsize=10)
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=8, loc="best")
    fig.tight_layout()
    return _png(fig)


def predictions(stretch: Record, model: TransferMatrix, plant: TransferMatrix | None) -> dict[str, np.ndarray]:
    """``y``, the model's and the plant's predictions from the stretch's inputs, shape (N, n_outputs) each.

    The filters start at the stretch's first input (steady state); a
    prediction is read after the slowest element settles.
    """
    out = {"y": stretch.y, "model": model.element_outputs(stretch.u).sum(axis=2)}
    if plant is not None:
        out["plant"] = plant.element_outputs(stretch.u).sum(axis=2)
    return out


def prediction_figure(
    stretch: Record,
    model: TransferMatrix,
    plant: TransferMatrix | None,
    *,
    labels: tuple[str, ...],
    time_unit: str = "",
) -> bytes | None:
    """Per CV: measured y against the model's and the estimated plant's prediction, and the model's residual, as PNG.

    The last :data:`PREDICTION_SAMPLES` samples of ``stretch`` (deviations from its means), after the settling.
    None when the stretch is shorter than the settling plus 50 samples.
    """
    settle = int(model.settling_samples())
    n = stretch.y.shape[0]
    if n < settle + 50:
        return None
    found = predictions(stretch, model, plant)
    first = max(settle, n - PREDICTION_SAMPLES)
    t = (np.arange(first, n) - first) * model.sample_time
    plt = _pyplot()
    rows = model.n_outputs
    fig, axes = plt.subplots(2 * rows, 1, figsize=(10.0, 1.0 + 2.2 * rows), sharex=True, squeeze=False,
                             height_ratios=[3, 1.2] * rows)  # fmt: skip
    for i in range(rows):
        ax, res = axes[2 * i, 0], axes[2 * i + 1, 0]
        y = found["y"][first:, i]
        ax.plot(t, y, color="#1565c0", lw=0.8, label="measured y")
        ax.plot(t, found["model"][first:, i], color="black", ls="--", lw=1.0, label="model's prediction")
        if "plant" in found:
            ax.plot(t, found["plant"][first:, i], color="#c62828", lw=1.0, label="estimated plant's prediction")
        ax.set_ylabel(labels[i], rotation=0, ha="right")
        res.plot(t, y - found["model"][first:, i], color="#616161", lw=0.6)
        res.axhline(0.0, color="black", lw=0.5)
        res.set_ylabel("y - model", fontsize=8)
        for a in (ax, res):
            a.grid(True, alpha=0.3)
    axes[0, 0].legend(fontsize=8, ncol=3, loc="lower left", bbox_to_anchor=(0.0, 1.02))
    axes[-1, 0].set_xlabel(f"time in the stretch [{time_unit or 'model time unit'}] (deviations from its means)")
    fig.tight_layout()
    return _png(fig)
