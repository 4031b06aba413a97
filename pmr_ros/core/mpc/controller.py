"""Linear constrained MPC: offset-free on any shape, integrating outputs included.

The controller predicts with its model ``Ghat`` (the state-space realization
of the transfer matrix, delays as shift registers), penalizes tracking error,
input moves and -- when there are more inputs than the outputs need -- the
inputs' distance from their targets, and respects input magnitude and rate
limits.  The QP is posed in the condensed form over the input moves ``dU`` of
the control horizon (:mod:`pmr_ros.core.mpc.design`):

    min  (Yfree + Theta dU - Ys)' Q (...) + dU' R dU + (U - Utarget)' M (U - Utarget)
    s.t. u_min <= u_prev + L dU <= u_max,  |dU| <= du_max

so its Hessian and constraint matrix never change: they are factored once, and
each step only the linear term and the bounds change.
The linear term and the unconstrained minimizer ``-H^-1 q`` are linear in
``z = [x; u_prev; r; d; p]``, so one precomputed matrix gives the moves in
one product.  When they satisfy every constraint they are the QP's solution
and are used directly; only when a limit would bind is the QP solved, exactly,
by the dual active-set method of :mod:`pmr_ros.core.mpc.qp` (OSQP stands by should
it break down) (``statistics`` counts how often).

Disturbance model (:mod:`pmr_ros.core.mpc.estimator`): every output carries an
estimated step ``d`` (the DMC/IMC output bias ``y - yhat``), and an integrating
output a ramp ``d + j p`` as well, so a constant unmeasured input disturbance
leaves no offset and no ramp on any output.

Model switch (:meth:`LinearMpc.switched`): a controller on a new model takes
over at a sample boundary without a bump.  Its QP is built for the new model;
its model state is the new model driven by the inputs applied so far (the
newest :data:`HISTORY_TIME_CONSTANTS` slowest time constants plus the longest
delay of them, which the controller keeps); the last input, the disturbance
slopes and the prediction of the current output (model output plus step
estimate) carry over.  At a steady state the new controller therefore makes
no move at all, whatever the new model.  Shapes
(:mod:`pmr_ros.core.mpc.design`): extra MVs rest at their input targets
(``input_target``, weighted by ``input_target_weight``) as far as the
setpoints allow; with more CVs than MVs the outputs settle at the
``Q``-weighted least-squares compromise; empty cells simply have no element.
"""

from __future__ import annotations

import time

import numpy as np
import osqp
import scipy.sparse as sp

from ..sim.model import TransferMatrix
from .design import (
    QpWeights,
    condensed_qp,
    input_target_penalty,
    prediction_matrices,
    steady_state_gain,
    target_map,
)
from .estimator import DisturbanceEstimator
from .qp import DenseQp
from .spec import MpcMatrices, MpcStatistics, MpcTuning

__all__ = ["HISTORY_TIME_CONSTANTS", "LinearMpc", "MpcMatrices", "MpcStatistics", "MpcTuning", "prediction_matrices"]

HISTORY_TIME_CONSTANTS = 16.0
"""Applied inputs kept for a model switch: this many of the model's slowest time constants plus its longest delay.

A FOPTD state forgets what came before to ``exp(-16)`` (1e-7); a new model
twice as slow still to ``exp(-8)``.  An integrating state never forgets, but
what it missed is a constant, which the carried-over step estimate absorbs."""


def _frozen(a: np.ndarray) -> np.ndarray:
    out = np.array(a, dtype=float, copy=True)
    out.flags.writeable = False
    return out


class LinearMpc:
    """Constrained MPC for a transfer-matrix model of any shape.

    Parameters
    ----------
    model : TransferMatrix
        The controller's model ``Ghat`` (deviation variables).
    tuning : MpcTuning
    record_solve_times : bool
        Keep each QP solve's wall time in ``statistics.solve_time_s``.
    always_solve_qp : bool
        Solve the QP every step, even when no constraint binds (for benchmarks
        and for checking the unconstrained shortcut).

    Attributes
    ----------
    estimator : DisturbanceEstimator
        The disturbance model (steps; ramps on integrating outputs).
    """

    def __init__(
        self,
        model: TransferMatrix,
        tuning: MpcTuning,
        *,
        record_solve_times: bool = False,
        always_solve_qp: bool = False,
    ) -> None:
        self.model = model
        self.always_solve_qp = always_solve_qp
        self.tuning = tuning
        Np, Nc = tuning.prediction_horizon, tuning.control_horizon
        if Nc > Np:
            raise ValueError("control_horizon must not exceed prediction_horizon")
        self._ss = ss = model.state_space()
        self._A, self._B, self._C = ss.A, ss.B, ss.C
        self.estimator = DisturbanceEstimator.for_model(model, filter_samples=tuning.ramp_filter_samples)
        qp = condensed_qp(
            ss,
            horizons=(Np, Nc),
            weights=self._weights(),
            targets=target_map(
                steady_state_gain(model), model.integrating_outputs, _vector(tuning.output_weight, model.n_outputs)
            ),
            estimator=self.estimator,
        )
        unconstrained = -np.linalg.solve(qp.hessian, np.eye(qp.hessian.shape[0]))  # dU* = this @ q
        self._gradient, self._gradient_offset = qp.gradient, qp.gradient_offset
        self._gain, self._gain_offset = unconstrained @ qp.gradient, unconstrained @ qp.gradient_offset
        n_in = model.n_inputs
        self._du = _vector(tuning.du_max, n_in)
        self._u_min, self._u_max = _vector(tuning.u_min, n_in), _vector(tuning.u_max, n_in)
        self._hessian, self._constraints = qp.hessian, np.vstack([qp.cumulative, np.eye(qp.cumulative.shape[0])])
        self._qp = DenseQp(self._hessian, self._constraints)
        self._fallback: osqp.OSQP | None = None  # set up on first need
        self.statistics = MpcStatistics(solve_time_s=[] if record_solve_times else None)
        self._history = np.zeros((max(model.settling_samples(HISTORY_TIME_CONSTANTS), Np), n_in))
        self.reset()

    def _weights(self) -> QpWeights:
        t, n_out, n_in = self.tuning, self.model.n_outputs, self.model.n_inputs
        penalty = input_target_penalty(steady_state_gain(self.model), _vector(t.input_target_weight, n_in))
        return QpWeights(
            _vector(t.output_weight, n_out), _vector(t.move_weight, n_in), _vector(t.input_target, n_in), penalty
        )

    def _setup_fallback(self, lower: np.ndarray, upper: np.ndarray) -> osqp.OSQP:
        """OSQP with the fixed Hessian and constraint matrix: the fallback should the active-set solver fail."""
        n_moves = self._hessian.shape[0]
        solver = osqp.OSQP()
        solver.setup(
            sp.triu(sp.csc_matrix(self._hessian), format="csc"),
            np.zeros(n_moves),
            sp.csc_matrix(self._constraints),
            lower,
            upper,
            verbose=False,
            warm_starting=True,
            eps_abs=1e-9,
            eps_rel=1e-9,
            max_iter=100000,
            polishing=True,
        )
        return solver

    def reset(self) -> None:
        """Forget the model state, past input and disturbance estimates (plant at rest)."""
        self._x = np.zeros(self._A.shape[0])
        self._u_prev = np.zeros(self.model.n_inputs)
        self._step = np.zeros(self.model.n_outputs)
        self._slope = np.zeros(self.estimator.n_ramps)
        self._history[:] = 0.0
        self._applied = 0  # inputs applied since the reset

    @property
    def applied_inputs(self) -> np.ndarray:
        """The inputs applied so far, oldest first, at most the history kept [input unit].

        Returns
        -------
        ndarray, shape (min(steps, kept), n_inputs)
        """
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

    def switched(self, model: TransferMatrix) -> LinearMpc:
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
        new = LinearMpc(model, self.tuning, always_solve_qp=self.always_solve_qp)
        new.take_over(self)
        return new

    def take_over(self, previous: LinearMpc) -> None:
        """Continue where ``previous`` (same channels) stopped, without a bump.

        The model state becomes this model driven by ``previous``'s
        :attr:`applied_inputs` from rest; the last input, the slope estimates
        of the integrating outputs both have, the statistics and the prediction
        of the current output (model output plus step estimate) carry over, so
        the innovation of the next measurement is the same for both.
        """
        inputs = previous.applied_inputs
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
        self.statistics = previous.statistics

    @property
    def matrices(self) -> MpcMatrices:
        """The controller's matrices as read-only copies (see :class:`MpcMatrices`)."""
        return MpcMatrices(
            A=_frozen(self._A),
            B=_frozen(self._B),
            C=_frozen(self._C),
            gain=_frozen(self._gain),
            gain_offset=_frozen(self._gain_offset),
            gradient=_frozen(self._gradient),
            gradient_offset=_frozen(self._gradient_offset),
        )

    @property
    def model_output(self) -> np.ndarray:
        """The model's prediction ``yhat(k)`` of the current output [output unit]."""
        return self._C @ self._x

    @property
    def disturbance(self) -> tuple[np.ndarray, np.ndarray]:
        """Current estimates: the step on every output and the slope on each integrating one."""
        return self._step.copy(), self._slope.copy()

    def step(self, y_measured: np.ndarray, setpoint: np.ndarray, *, dither: np.ndarray | None = None) -> np.ndarray:
        """Compute ``u(k)`` from ``y(k)`` and ``r(k)``; advance the internal model.

        Parameters
        ----------
        y_measured : array_like, shape (n_outputs,)
            Measured outputs [output unit].
        setpoint : array_like, shape (n_outputs,)
            Setpoints [output unit], held over the horizon.
        dither : array_like, shape (n_inputs,), optional
            An external test signal added to the controller's output, as a
            step tester adds small moves to a running MPC [input unit].  The
            applied input ``u + dither`` (kept within the input limits) goes to
            the plant and into the controller's model, so the dither is not
            mistaken for a disturbance; the move limits apply to the
            controller's own moves.

        Returns
        -------
        ndarray, shape (n_inputs,)
            The input to apply over the next sample [input unit].
        """
        residual = np.asarray(y_measured, dtype=float) - self._C @ self._x
        self._step, self._slope = self.estimator.update(residual, self._step, self._slope)
        z = np.concatenate((self._x, self._u_prev, np.asarray(setpoint, dtype=float), self._step, self._slope))
        self.statistics.steps += 1
        moves = self._gain @ z + self._gain_offset
        if self.always_solve_qp or not self.within_limits(moves, self._u_prev):
            lower, upper = self.move_bounds(self._u_prev)
            move = self.solve_constrained(self._gradient @ z + self._gradient_offset, lower=lower, upper=upper)
        else:
            move = moves[: self.model.n_inputs]
        u, applied = self.apply_move(self._u_prev, move, dither)
        self._x = self.advance_model(self._x, applied)
        self._u_prev = u
        self._history[self._applied % self._history.shape[0]] = applied
        self._applied += 1
        return applied

    def advance_model(self, x: np.ndarray, applied: np.ndarray) -> np.ndarray:
        """The model's next state ``A x + B u`` after the applied input (rows of a batch alike)."""
        return self._ss.advance(x, applied)

    def within_limits(self, moves: np.ndarray, u_prev: np.ndarray) -> np.ndarray:
        """Whether moves ``dU`` keep every move and magnitude limit (per row of a batch).

        Parameters
        ----------
        moves : ndarray, shape (..., Nc*n_in)
            Moves of the control horizon [input unit].
        u_prev : ndarray, shape (..., n_in)
            The input before them [input unit].

        Returns
        -------
        bool or ndarray of bool, shape (...)
        """
        steps = moves.reshape(*moves.shape[:-1], self.tuning.control_horizon, self.model.n_inputs)
        path = u_prev[..., None, :] + np.cumsum(steps, axis=-2)
        ok = (np.abs(steps) <= self._du) & (path >= self._u_min) & (path <= self._u_max)
        return ok.reshape(moves.shape).all(axis=-1)

    def move_bounds(self, u_prev: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Lower and upper bounds of the QP's constraints ``[L dU; dU]`` after input ``u_prev`` [input unit]."""
        Nc = self.tuning.control_horizon
        u_rep, du = np.tile(u_prev, Nc), np.tile(self._du, Nc)
        return (
            np.concatenate([np.tile(self._u_min, Nc) - u_rep, -du]),
            np.concatenate([np.tile(self._u_max, Nc) - u_rep, du]),
        )

    def apply_move(
        self, u_prev: np.ndarray, move: np.ndarray, dither: np.ndarray | None
    ) -> tuple[np.ndarray, np.ndarray]:
        """The controller's input after ``move`` and the applied input with the dither, both within limits.

        Works row by row on a batch (``(..., n_in)`` arrays).

        Returns
        -------
        u, applied : ndarray
            ``u_prev + move`` (move and magnitude limits held) and ``u + dither`` (magnitude limits held).
        """
        # np.minimum(np.maximum(.)) is np.clip, without its overhead on short vectors
        bounded = np.minimum(np.maximum(move, -self._du), self._du)
        u = np.minimum(np.maximum(u_prev + bounded, self._u_min), self._u_max)
        applied = u if dither is None else np.minimum(np.maximum(u + dither, self._u_min), self._u_max)
        return u, applied

    def solve_constrained(self, q: np.ndarray, *, lower: np.ndarray, upper: np.ndarray) -> np.ndarray:
        """The first move of the constrained QP for linear term ``q`` and the bounds of ``[L dU; dU]``.

        Solved exactly by the dual active-set method (:class:`~pmr_ros.core.mpc.qp.DenseQp`); should it
        break down, by OSQP; should that fail too, the input is held (a zero move), the safe fallback of
        industrial MPC.  Counts the solve in :attr:`statistics`.
        """
        t0 = time.perf_counter()
        solution = self._qp.solve(q, lower=lower, upper=upper)
        x = solution.x if solution.solved else self._solve_fallback(q, lower, upper)
        elapsed = time.perf_counter() - t0
        stats = self.statistics
        stats.solves += 1
        if stats.solve_time_s is not None:
            stats.solve_time_s.append(elapsed)
        n_in = self.model.n_inputs
        if x is not None:
            return x[:n_in]
        stats.failures += 1
        return np.zeros(n_in)

    def _solve_fallback(self, q: np.ndarray, lower: np.ndarray, upper: np.ndarray) -> np.ndarray | None:
        """OSQP's solution, or None when it fails too."""
        self.statistics.fallbacks += 1
        if self._fallback is None:
            self._fallback = self._setup_fallback(lower, upper)
        self._fallback.update(q=q, l=lower, u=upper)
        result = self._fallback.solve(raise_error=False)
        if result.info.status_val in (osqp.SolverStatus.OSQP_SOLVED, osqp.SolverStatus.OSQP_SOLVED_INACCURATE):
            return result.x
        return None


def _vector(values: np.ndarray, n: int) -> np.ndarray:
    """One float per channel (a scalar stands for every channel)."""
    return np.broadcast_to(np.asarray(values, dtype=float), (n,)).copy()
