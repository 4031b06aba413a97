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
``z = [x; u_prev; v; r; d; p]`` (``v`` the measured disturbances, when there
is a DV model), so one precomputed matrix gives the moves in one product.
When they satisfy every constraint they are the QP's solution and are used
directly; only when a limit would bind is the QP solved, exactly, by the dual
active-set method of :mod:`pmr_ros.core.mpc.qp` (OSQP stands by should it
break down: :mod:`pmr_ros.core.mpc.solver`) (``statistics`` counts how often).

Disturbance model (:mod:`pmr_ros.core.mpc.estimator`): every output carries an
estimated step ``d`` (the DMC/IMC output bias ``y - yhat``), and an integrating
output a ramp ``d + j p`` as well, so a constant unmeasured input disturbance
leaves no offset and no ramp on any output.

Routine operation: measured disturbances (DVs) enter as feedforward -- the
model is ``[Ghat, Ghat_d]``, its state advanced with the applied inputs and the
measured DVs, and the prediction holds each DV at its current value over the
horizon; CVs may have soft zones and limits instead of setpoints
(:mod:`pmr_ros.core.mpc.zones`); an MV in manual (its controller off) is a
given input: its moves are fixed to the operator's in the QP and its value
goes into the model like any applied input.

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

import numpy as np

from ..sim.augment import augmented_model
from ..sim.model import TransferMatrix
from .design import (
    CondensedQp,
    QpWeights,
    condensed_qp,
    input_target_penalty,
    prediction_matrices,
    steady_state_gain,
    target_map,
)
from .estimator import DisturbanceEstimator
from .given_inputs import GivenInputs
from .solver import QpSolver
from .spec import MpcMatrices, MpcStatistics, MpcTuning
from .switch import ModelSwitch
from .zones import ZoneQp, ZoneTarget, zone_qp

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


class LinearMpc(GivenInputs, ModelSwitch):
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
    disturbance_model : TransferMatrix, optional
        ``Ghat_d``: the measured disturbances' model (n_outputs x n_disturbances),
        used as feedforward; :meth:`step` then needs the measured DVs.

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
        disturbance_model: TransferMatrix | None = None,
    ) -> None:
        self.model = model
        self.always_solve_qp = always_solve_qp
        self.tuning = tuning
        self.disturbance_model = disturbance_model
        self.n_disturbances = 0 if disturbance_model is None else disturbance_model.n_inputs
        Np, Nc = tuning.prediction_horizon, tuning.control_horizon
        if Nc > Np:
            raise ValueError("control_horizon must not exceed prediction_horizon")
        whole = model if disturbance_model is None else augmented_model(model, disturbance_model)
        self._ss = ss = whole.state_space()
        self._A, self._B, self._C = ss.A, ss.B, ss.C
        self.estimator = DisturbanceEstimator.for_model(model, filter_samples=tuning.ramp_filter_samples)
        weights = self._weights()
        qp = condensed_qp(
            ss,
            horizons=(Np, Nc),
            weights=weights,
            targets=target_map(self._tracked_gain(), model.integrating_outputs, weights.output),
            estimator=self.estimator,
            n_disturbances=self.n_disturbances,
        )
        unconstrained = -np.linalg.solve(qp.hessian, np.eye(qp.hessian.shape[0]))  # dU* = this @ q
        self._gradient, self._gradient_offset = qp.gradient, qp.gradient_offset
        self._gain, self._gain_offset = unconstrained @ qp.gradient, unconstrained @ qp.gradient_offset
        n_in = model.n_inputs
        self._du = _vector(tuning.du_max, n_in)
        self._u_min, self._u_max = _vector(tuning.u_min, n_in), _vector(tuning.u_max, n_in)
        constraints = np.vstack([qp.cumulative, np.eye(qp.cumulative.shape[0])])
        du = np.tile(self._du, Nc)
        self._bounds = np.concatenate([np.tile(self._u_min, Nc), -du]), np.concatenate([np.tile(self._u_max, Nc), du])
        self._tiled_input = np.tile(np.arange(n_in), Nc)  # u_prev[this] is np.tile(u_prev, Nc), without its overhead
        self.statistics = MpcStatistics(solve_time_s=[] if record_solve_times else None)
        self._solver = QpSolver(qp.hessian, constraints, self.statistics)
        self._zones: ZoneQp | None = None
        self._zone_solver: QpSolver | None = None
        self._zone_target: ZoneTarget | None = None
        if tuning.zones_active and np.any(tuning.limited_outputs):
            self._setup_zones(qp, constraints, unconstrained)
        self._history = np.zeros((max(whole.settling_samples(HISTORY_TIME_CONSTANTS), Np), n_in + self.n_disturbances))
        self.reset()

    def _setup_zones(self, qp: CondensedQp, constraints: np.ndarray, unconstrained: np.ndarray) -> None:
        """The QP with the soft zones (:mod:`pmr_ros.core.mpc.zones`) and the zone-respecting input target."""
        t, n_out, n_in = self.tuning, self.model.n_outputs, self.model.n_inputs
        self._zones = zone_qp(
            self._ss,
            horizons=(t.prediction_horizon, t.control_horizon),
            estimator=self.estimator,
            plain=(qp.hessian, qp.gradient, qp.gradient_offset, constraints),
            zones=(t.output_low, t.output_high, _vector(t.zone_weight, n_out)),
            n_disturbances=self.n_disturbances,
        )
        self._zone_solver = QpSolver(self._zones.hessian, self._zones.constraints, self.statistics)
        self._zone_target = ZoneTarget(
            tracked_gain=self._tracked_gain(),
            steady_gain=steady_state_gain(self.model),
            integrating=self.model.integrating_outputs,
            zones=(t.output_low, t.output_high),
            weight=_vector(t.input_target_weight, n_in),
            input_target=_vector(t.input_target, n_in),
        )
        self._target_gradient, self._target_gain = qp.target_gradient, unconstrained @ qp.target_gradient

    def _weights(self) -> QpWeights:
        t, n_out, n_in = self.tuning, self.model.n_outputs, self.model.n_inputs
        penalty = input_target_penalty(self._tracked_gain(), _vector(t.input_target_weight, n_in))
        output = _vector(t.output_weight, n_out)
        if t.zones_active:  # a zone CV has no tracking penalty
            output = np.where(self._zone_outputs(), 0.0, output)
        return QpWeights(output, _vector(t.move_weight, n_in), _vector(t.input_target, n_in), penalty)

    def _tracked_gain(self) -> np.ndarray:
        """The steady-state gain of what the setpoints fix: a stable zone CV's row is free (zero).

        An integrating zone CV keeps its rate row: a steady state needs its level still, wherever in the zone.
        """
        gain = steady_state_gain(self.model)
        if not self.tuning.zones_active:
            return gain
        free = self._zone_outputs() & ~self.model.integrating_outputs
        return np.where(free[:, None], 0.0, gain)

    def _zone_outputs(self) -> np.ndarray:
        zone = self.tuning.zone_outputs
        return zone if zone.size else np.zeros(self.model.n_outputs, dtype=bool)

    def reset(self) -> None:
        """Forget the model state, past input and disturbance estimates (plant at rest)."""
        self._x = np.zeros(self._A.shape[0])
        self._u_prev = np.zeros(self.model.n_inputs)
        self._step = np.zeros(self.model.n_outputs)
        self._slope = np.zeros(self.estimator.n_ramps)
        self._history[:] = 0.0
        self._applied = 0  # inputs applied since the reset

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

    def step(
        self,
        y_measured: np.ndarray,
        setpoint: np.ndarray,
        *,
        dither: np.ndarray | None = None,
        disturbance: np.ndarray | None = None,
        manual_input: np.ndarray | None = None,
    ) -> np.ndarray:
        """Compute ``u(k)`` from ``y(k)`` and ``r(k)``; advance the internal model.

        Parameters
        ----------
        y_measured : array_like, shape (n_outputs,)
            Measured outputs [output unit].
        setpoint : array_like, shape (n_outputs,)
            Setpoints [output unit], held over the horizon (a zone CV's is not tracked).
        dither : array_like, shape (n_inputs,), optional
            An external test signal added to the controller's output, as a
            step tester adds small moves to a running MPC [input unit].  The
            applied input ``u + dither`` (kept within the input limits) goes to
            the plant and into the controller's model, so the dither is not
            mistaken for a disturbance; the move limits apply to the
            controller's own moves.
        disturbance : array_like, shape (n_disturbances,), optional
            The measured DVs ``v(k)`` (held over the next sample) [DV unit];
            needed with a DV model: its predicted effect enters the prediction
            (feedforward) and ``v(k)`` advances the model with ``u(k)``.
        manual_input : array_like, shape (n_inputs,), optional
            The operator's value of each MV in manual (its controller off), NaN for the MVs in
            automatic [input unit]: a given input, its moves fixed in the QP, its value applied (no dither).

        Returns
        -------
        ndarray, shape (n_inputs,)
            The input to apply over the next sample [input unit].
        """
        residual = np.asarray(y_measured, dtype=float) - self._C @ self._x
        self._step, self._slope = self.estimator.update(residual, self._step, self._slope)
        measured = self._measured(disturbance)
        parts = (self._x, self._u_prev, measured) if self.n_disturbances else (self._x, self._u_prev)
        z = np.concatenate((*parts, np.asarray(setpoint, dtype=float), self._step, self._slope))
        self.statistics.steps += 1
        offsets = self._offsets(np.asarray(setpoint, dtype=float))
        moves = self._gain @ z + offsets[0]
        manual = self.manual_inputs(manual_input)
        limits_ok = self.within_limits(moves, self._u_prev)
        zones_ok = self._zones is None or self._zones.inside(z, moves)
        if self.always_solve_qp or manual is not None or not (limits_ok and zones_ok):
            move = self._constrained_move(z, offsets[1], manual, plain_first=not limits_ok)
        else:
            move = moves[: self.model.n_inputs]
        u, applied = self.apply_move(self._u_prev, move, dither)
        if manual is not None:  # the operator's value, without dither
            u, applied = np.where(np.isfinite(manual), manual, u), np.where(np.isfinite(manual), manual, applied)
        self._advance(u, applied, measured)
        return applied

    def _advance(self, u: np.ndarray, applied: np.ndarray, measured: np.ndarray) -> None:
        """Advance the model with the applied inputs and the measured DVs; keep them in the history."""
        whole = np.concatenate((applied, measured)) if self.n_disturbances else applied
        self._x = self._ss.advance(self._x, whole)
        self._u_prev = u
        self._history[self._applied % self._history.shape[0]] = whole
        self._applied += 1

    def _offsets(self, setpoint: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The input target's terms of the unconstrained moves and of the QP's linear term, this step.

        Fixed without zones; with zones from the target calculation (:class:`~pmr_ros.core.mpc.zones.ZoneTarget`).
        """
        if self._zone_target is None:
            return self._gain_offset, self._gradient_offset
        target = self._zone_target.input_target(setpoint, self._step, self._slope)
        return self._target_gain @ target, self._target_gradient @ target

    def _constrained_move(
        self, z: np.ndarray, offset: np.ndarray, manual_input: np.ndarray | None, *, plain_first: bool = True
    ) -> np.ndarray:
        """The first move of the QP (with the zones, when there are any); a manual MV's moves fixed.

        With zones, ``plain_first``: the plain QP first (an input limit binds), its answer taken when it keeps
        every zone; else (or when the unconstrained moves already left a zone) the QP with the zones.
        """
        lower, upper = self.move_bounds(self._u_prev)
        if manual_input is not None:
            self._pin_manual(lower, upper, np.asarray(manual_input, dtype=float))
        q = self._gradient @ z + offset
        if self._zones is None or self._zone_solver is None:
            return self.solve_constrained(q, lower=lower, upper=upper)
        zones = self._zones
        x = self._solver.solve(q, lower=lower, upper=upper) if plain_first else None
        if x is not None and zones.inside(z, x):  # only an input limit binds: the plain QP's answer stands
            return x[: self.model.n_inputs]
        x = self._zone_solver.solve(
            zones.gradient @ z + np.concatenate([offset, np.zeros(zones.low.size)]),
            lower=np.concatenate([lower, zones.low]),
            upper=np.concatenate([upper, zones.high]),
        )
        return np.zeros(self.model.n_inputs) if x is None else x[: self.model.n_inputs]

    def advance_model(self, x: np.ndarray, applied: np.ndarray) -> np.ndarray:
        """The model's next state ``A x + B u`` after the applied input (rows of a batch alike; no DV model)."""
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
        (lower, upper), u_rep = self._bounds, u_prev[self._tiled_input]  # fixed parts tiled once; u_prev, Nc times
        n = u_rep.size  # the magnitude rows move with u_prev
        return np.concatenate([lower[:n] - u_rep, lower[n:]]), np.concatenate([upper[:n] - u_rep, upper[n:]])

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
        industrial MPC (:class:`~pmr_ros.core.mpc.solver.QpSolver`).  Counts the solve in :attr:`statistics`.
        """
        x = self._solver.solve(q, lower=lower, upper=upper)
        n_in = self.model.n_inputs
        return np.zeros(n_in) if x is None else x[:n_in]


def _vector(values: np.ndarray, n: int) -> np.ndarray:
    """One float per channel (a scalar stands for every channel)."""
    return np.broadcast_to(np.asarray(values, dtype=float), (n,)).copy()
