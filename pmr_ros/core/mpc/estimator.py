"""The MPC's disturbance model and its estimator: output steps, and ramps on integrating outputs.

The controller's model runs open loop beside the plant (IMC/DMC structure);
what the plant's measurements differ from it by, the residual
``e(k) = y(k) - C x(k)``, is explained by an unmeasured disturbance that the
predictions carry over the horizon:

* a **stable output** (every element FOPTD or empty) gets a constant output
  step ``d``, estimated deadbeat, ``d(k) = e(k)``: the DMC/IMC output bias.  A
  constant unmeasured input disturbance on a stable output settles to a
  constant output offset, which the bias removes.
* an **integrating output** (a level, a gas pressure) gets a step *and a ramp*:
  ``d(k+1) = d(k) + p(k)``, ``p(k+1) = p(k)``, and the predictions extend the
  ramp, ``d + j p`` at ``k + j``.  A constant unmeasured input disturbance on
  an integrating output (an unmeasured inflow into a tank) makes the residual
  a ramp of slope ``p``; a constant bias would predict the level flat, so the
  controller would sit at a steady offset or let the level ramp.  With the
  ramp the steady state is ``y = r`` again: the controller holds the inputs
  where the modelled rate cancels ``p``.  This is the integrated (input-side)
  disturbance model of Pannocchia & Rawlings (2003) restricted to the outputs
  that need it, chosen over input disturbances on the MVs because it needs no
  choice of which MV the disturbance enters (there are more MVs than CVs) and
  is observable from the one measurement of each CV.

The ramp is estimated by the steady-state filter of that two-state model (an
alpha-beta filter) with both error poles at ``rho = exp(-1 / T)``, ``T`` the
``ramp_filter_samples`` of the tuning: ``alpha = 1 - rho^2``,
``beta = (1 - rho)^2``.  ``T = 0`` is deadbeat (``p`` from the last two
residuals, noisy); larger ``T`` averages the measurement noise out of the
slope at the price of a slower reaction to a new disturbance.  Being a type-2
filter it follows a ramp without steady error, so a constant load leaves no
offset whatever ``T``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..sim.model import TransferMatrix

__all__ = ["DisturbanceEstimator", "ramp_filter_gains"]


def ramp_filter_gains(filter_samples: float) -> tuple[float, float]:
    """``(alpha, beta)`` of the ramp estimator with both error poles at ``exp(-1 / filter_samples)``.

    Parameters
    ----------
    filter_samples : float
        Time constant T of the estimate [samples], >= 0; 0 is deadbeat.

    Returns
    -------
    alpha, beta : float
        Gains of the innovation on the step and on the slope.
    """
    if not filter_samples >= 0:
        raise ValueError(f"ramp filter time constant must be >= 0 samples, got {filter_samples!r}")
    rho = math.exp(-1.0 / filter_samples) if filter_samples > 0 else 0.0
    return 1.0 - rho * rho, (1.0 - rho) ** 2


@dataclass(frozen=True)
class DisturbanceEstimator:
    """Steps on every output, ramps on the integrating ones; estimated from the residual.

    Works on one loop (arrays of shape ``(n_outputs,)``) and on a batch of
    loops (``(n_runs, n_outputs)``) with the same floating-point operations.

    Attributes
    ----------
    integrating : ndarray of int
        Indices of the integrating outputs (those with a ramp).
    alpha, beta : float
        Innovation gains on the step and on the slope (:func:`ramp_filter_gains`).
    """

    integrating: np.ndarray
    alpha: float
    beta: float

    @classmethod
    def for_model(cls, model: TransferMatrix, *, filter_samples: float) -> DisturbanceEstimator:
        """The estimator of ``model``'s outputs, ramps on its integrating ones.

        Parameters
        ----------
        model : TransferMatrix
            The controller's model.
        filter_samples : float
            Time constant of the ramp estimate [samples].
        """
        alpha, beta = ramp_filter_gains(filter_samples)
        return cls(np.flatnonzero(model.integrating_outputs), alpha, beta)

    @property
    def n_ramps(self) -> int:
        """Ramp (slope) states: one per integrating output."""
        return int(self.integrating.size)

    def update(self, residual: np.ndarray, step: np.ndarray, slope: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The estimates at sample k from the residual ``e(k)`` and the estimates at k - 1.

        Parameters
        ----------
        residual : ndarray, shape (..., n_outputs)
            ``y(k) - yhat(k)`` [output unit].
        step : ndarray, shape (..., n_outputs)
            Step estimates ``d(k-1)`` [output unit].
        slope : ndarray, shape (..., n_ramps)
            Slope estimates ``p(k-1)`` of the integrating outputs [output unit per sample].

        Returns
        -------
        step, slope : ndarray
            ``d(k)`` and ``p(k)``; the inputs are not changed.
        """
        new_step = np.array(residual, dtype=float, copy=True)  # stable outputs: deadbeat bias
        if not self.n_ramps:
            return new_step, slope
        rows = self.integrating
        predicted = step[..., rows] + slope
        innovation = new_step[..., rows] - predicted
        new_step[..., rows] = predicted + self.alpha * innovation
        return new_step, slope + self.beta * innovation
