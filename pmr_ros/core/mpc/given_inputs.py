"""The inputs the MPC does not decide: measured disturbances (feedforward) and MVs in manual.

A measured disturbance ``v`` (a DV) is read each step, held over the horizon
in the prediction and fed with the applied inputs into the model state; an MV
whose controller is off is a given input: its moves are fixed in the QP to
the operator's value and none after.
"""

from __future__ import annotations

import numpy as np

from ..sim.model import StateSpace, TransferMatrix
from .design import prediction_matrices
from .spec import MpcTuning

__all__ = ["GivenInputs"]


class GivenInputs:
    """The measured-disturbance and manual-MV part of :class:`~pmr_ros.core.mpc.controller.LinearMpc`."""

    model: TransferMatrix
    tuning: MpcTuning
    n_disturbances: int
    _ss: StateSpace
    _x: np.ndarray
    _u_prev: np.ndarray

    def _measured(self, disturbance: np.ndarray | None) -> np.ndarray:
        """The measured DVs as a vector; a controller with a DV model needs them."""
        if not self.n_disturbances:
            return np.zeros(0)
        if disturbance is None:
            raise ValueError(f"this controller has a model of {self.n_disturbances} measured disturbances: give them")
        return np.broadcast_to(np.asarray(disturbance, dtype=float), (self.n_disturbances,)).copy()

    @staticmethod
    def manual_inputs(manual_input: np.ndarray | None) -> np.ndarray | None:
        """The operator's values as floats (NaN: automatic), or None when every MV is in automatic."""
        if manual_input is None:
            return None
        given = np.asarray(manual_input, dtype=float)
        return given if np.any(np.isfinite(given)) else None

    def _pin_manual(self, lower: np.ndarray, upper: np.ndarray, manual_input: np.ndarray) -> None:
        """Fix a manual MV's moves in the bounds of ``[L dU; dU]``: to the operator's value now, none after."""
        n_in, Nc = self.model.n_inputs, self.tuning.control_horizon
        for j in np.flatnonzero(np.isfinite(manual_input)).tolist():
            path = np.arange(Nc) * n_in + j
            lower[path], upper[path] = -np.inf, np.inf  # the path follows the fixed moves; no second row on them
            lower[Nc * n_in + path], upper[Nc * n_in + path] = 0.0, 0.0
            lower[Nc * n_in + j] = upper[Nc * n_in + j] = manual_input[j] - self._u_prev[j]

    def prediction(self, disturbance: np.ndarray | None = None) -> np.ndarray:
        """The model's outputs over the horizon with the inputs held and no move, without the disturbance estimates.

        ``yhat(k+j) = C A^j x + S_j [u_prev; v]`` for ``j = 1 .. Np``: what the model alone expects
        (the feedforward part of the prediction) [output unit], shape (Np, n_outputs).
        """
        Np = self.tuning.prediction_horizon
        Phi, Psi, _ = prediction_matrices(self._ss, prediction_horizon=Np, control_horizon=1)
        held = np.concatenate((self._u_prev, self._measured(disturbance)))
        return (Phi @ self._x + Psi @ held).reshape(Np, self.model.n_outputs)
