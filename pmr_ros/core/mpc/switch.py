"""Model switch of the MPC: a controller on a new model takes over at a sample boundary without a bump.

Its QP is built for the new model; its model state is the new model driven by
the inputs (and measured disturbances) applied so far -- the newest
:data:`~pmr_ros.core.mpc.controller.HISTORY_TIME_CONSTANTS` slowest time
constants plus the longest delay of them, which the controller keeps; the last
input, the disturbance slopes and the prediction of the current output (model
output plus step estimate) carry over.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any, TypeVar

import numpy as np

from ..sim.model import StateSpace, TransferMatrix
from .estimator import DisturbanceEstimator
from .spec import MpcStatistics, MpcTuning

if TYPE_CHECKING:
    from .solver import QpSolver

__all__ = ["ModelSwitch"]

_Controller = TypeVar("_Controller", bound="ModelSwitch")
"""The controller class a switch builds (a subclass: :class:`~pmr_ros.core.mpc.controller.LinearMpc`)."""


class ModelSwitch:
    """The model-switch part of :class:`~pmr_ros.core.mpc.controller.LinearMpc` (its state is the controller's)."""

    model: TransferMatrix
    tuning: MpcTuning
    disturbance_model: TransferMatrix | None
    always_solve_qp: bool
    estimator: DisturbanceEstimator
    statistics: MpcStatistics
    _ss: StateSpace
    _A: np.ndarray
    _x: np.ndarray
    _u_prev: np.ndarray
    _step: np.ndarray
    _slope: np.ndarray
    _history: np.ndarray
    _applied: int
    _solver: QpSolver
    _zone_solver: QpSolver | None

    def __init__(self, *args: Any, **kwargs: Any) -> None:  # the controller's own constructor does the work
        raise NotImplementedError

    @property
    def model_output(self) -> np.ndarray:
        """The model's prediction ``yhat(k)`` of the current output [output unit]."""
        raise NotImplementedError

    @property
    def disturbance(self) -> tuple[np.ndarray, np.ndarray]:
        """Current estimates: the step on every output and the slope on each integrating one."""
        raise NotImplementedError

    @property
    def applied_inputs(self) -> np.ndarray:
        """The inputs applied so far, oldest first, at most the history kept [input unit].

        Returns
        -------
        ndarray, shape (min(steps, kept), n_inputs)
        """
        return self._applied_history()[:, : self.model.n_inputs]

    def _applied_history(self) -> np.ndarray:
        """The applied inputs and the measured DVs beside them, oldest first, shape (steps kept, n_in + n_dv)."""
        kept = self._history.shape[0]
        if self._applied <= kept:
            return self._history[: self._applied].copy()
        return np.roll(self._history, -(self._applied % kept), axis=0)

    def switch_problem(self, model: TransferMatrix) -> str | None:
        """Why this controller cannot switch to ``model`` (other channels or sample time), or None."""
        old = self.model
        if (model.output_names, model.input_names) != (old.output_names, old.input_names):
            return (
                f"the new model's channels ({', '.join(model.output_names)}; {', '.join(model.input_names)}) are not "
                f"the controller's ({', '.join(old.output_names)}; {', '.join(old.input_names)})"
            )
        if model.sample_time != old.sample_time:
            return f"the new model's sample time {model.sample_time:g} is not the controller's {old.sample_time:g}"
        return None

    def switched(self: _Controller, model: TransferMatrix) -> _Controller:
        """A controller on ``model``, same tuning, that takes over from this one without a bump.

        Its QP is built for ``model``, then it :meth:`take_over` this one's
        state.  Call it between two steps: the new controller computes the next
        sample.

        Parameters
        ----------
        model : TransferMatrix
            The new model; same outputs, inputs and sample time.

        Returns
        -------
        LinearMpc

        Raises
        ------
        ValueError
            Other channels or another sample time (:meth:`switch_problem`), or a
            model the tuning cannot control (a singular QP).
        """
        problem = self.switch_problem(model)
        if problem:
            raise ValueError(problem)
        new = type(self)(
            model, self.tuning, always_solve_qp=self.always_solve_qp, disturbance_model=self.disturbance_model
        )
        new.take_over(self)
        return new

    def take_over(self, previous: ModelSwitch) -> None:
        """Continue where ``previous`` (same channels) stopped, without a bump.

        The model state becomes this model driven by ``previous``'s
        :attr:`applied_inputs` from rest; the last input, the slope estimates
        of the integrating outputs both have, the statistics and the prediction
        of the current output (model output plus step estimate) carry over, so
        the innovation of the next measurement is the same for both.
        """
        inputs = previous._applied_history()
        n_whole = self._history.shape[1]  # the DVs beside the inputs; a DV the other had not is taken as 0
        inputs = np.hstack([inputs, np.zeros((inputs.shape[0], max(0, n_whole - inputs.shape[1])))])[:, :n_whole]
        x = np.zeros(self._A.shape[0])
        for u in inputs:
            x = self._ss.advance(x, u)
        self._x = x
        self._u_prev = previous._u_prev.copy()
        held = inputs[-self._history.shape[0] :]
        self._history[: held.shape[0]] = held
        self._applied = held.shape[0]
        step, slope = previous.disturbance
        self._step = step + (previous.model_output - self.model_output)
        slopes = dict(zip(previous.estimator.integrating.tolist(), slope, strict=True))
        self._slope = np.array([slopes.get(int(i), 0.0) for i in self.estimator.integrating])
        self.statistics = self._solver.statistics = previous.statistics
        if self._zone_solver is not None:
            self._zone_solver.statistics = previous.statistics
