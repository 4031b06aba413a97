"""Soft output zones and limits of the MPC: a CV held inside ``low .. high`` instead of at a setpoint.

Most CVs of a running MPC have zones or limits, not setpoints.  A zone CV has
no tracking penalty; every CV with a finite limit is held inside it softly: at
a few checked points ``j`` of the horizon the QP gets a free target ``t`` per
limited CV, bounded to its zone, and the cost ``w (yhat - t)^2``:

    min  J(dU) + sum_points w (yhat_j(dU) - t_j)^2   s.t.  low <= t_j <= high

Inside its zone ``t = yhat`` costs nothing; outside, the cost is ``w`` times the
squared distance to the zone (a soft constraint: a slack whose square is
penalized, so the QP is always feasible).  The points reach to the end of the
horizon, which covers the settling, and the input target the controller
heads for is moved each step to a steady state inside the zones
(:class:`ZoneTarget`): the target calculation respects the zones, with the
setpoints first, the zones next and the input targets last.  Zone CVs take
no part in the setpoint compromise of :func:`~pmr_ros.core.mpc.design.target_map`.

The extra variables exist only in the constrained solve.  When the
unconstrained moves keep every input limit and every predicted limited output
inside its zone, they are the solution of the extended QP as well (``t = yhat``
at zero cost), so the controller's fast path is unchanged.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..sim.model import StateSpace
from .design import null_space, prediction_matrices, split_disturbances
from .estimator import DisturbanceEstimator
from .qp import DenseQp

__all__ = ["ZONE_POINTS", "ZoneQp", "ZoneTarget", "zone_points", "zone_qp"]

ZONE_POINTS = 10
"""Checked points of the horizon per limited CV (fewer when the horizon is shorter)."""


def zone_points(prediction_horizon: int, count: int = ZONE_POINTS) -> np.ndarray:
    """The checked horizon steps (1-based), evenly spread, the last one ``prediction_horizon``.

    Examples
    --------
    >>> zone_points(40, 4).tolist()
    [10, 20, 30, 40]
    """
    n = min(count, prediction_horizon)
    return np.unique(np.rint(np.linspace(prediction_horizon / n, prediction_horizon, n)).astype(int))


@dataclass(frozen=True)
class ZoneQp:
    """The QP over ``[dU; t]`` with the zone costs, its linear term linear in ``z`` as the plain one's.

    Attributes
    ----------
    hessian : ndarray, shape (n_moves + n_t, n_moves + n_t)
    gradient : ndarray, shape (n_moves + n_t, nz)
    gradient_offset : ndarray, shape (n_moves + n_t,)
    constraints : ndarray
        ``blockdiag(input constraints, I)``: the plain QP's rows, then ``t``'s bounds.
    low, high : ndarray, shape (n_t,)
        The zones of the targets ``t`` [output unit].
    prediction : ndarray, shape (n_t, nz)
        The limited outputs at the checked points with the input held (no moves), from ``z``.
    moves : ndarray, shape (n_t, n_moves)
        Their change per move.
    """

    hessian: np.ndarray
    gradient: np.ndarray
    gradient_offset: np.ndarray
    constraints: np.ndarray
    low: np.ndarray
    high: np.ndarray
    prediction: np.ndarray
    moves: np.ndarray

    def inside(self, z: np.ndarray, moves: np.ndarray) -> bool:
        """Whether the moves keep every limited output inside its zone at every checked point."""
        y = self.prediction @ z + self.moves @ moves
        return bool(np.all((y >= self.low) & (y <= self.high)))


def _prediction_rows(
    ss: StateSpace, *, horizons: tuple[int, int], estimator: DisturbanceEstimator, n_disturbances: int
) -> tuple[np.ndarray, np.ndarray]:
    """Every output at every horizon step from ``z = [x; u_prev; v; r; d; p]`` and from the moves."""
    Np, Nc = horizons
    n_out = ss.C.shape[0]
    n_in = ss.B.shape[1] - n_disturbances
    Phi, Psi, Theta = prediction_matrices(ss, prediction_horizon=Np, control_horizon=Nc)
    Psi, Psi_v, Theta = split_disturbances(Psi, Theta, n_inputs=n_in, control_horizon=Nc)
    step = np.tile(np.eye(n_out), (Np, 1))  # d held
    ramp = np.kron(np.arange(1.0, Np + 1.0)[:, None], np.eye(n_out)[:, estimator.integrating])  # + j p
    free = np.hstack([Phi, Psi, Psi_v, np.zeros((Np * n_out, n_out)), step, ramp])
    return free, Theta


def zone_qp(
    ss: StateSpace,
    *,
    horizons: tuple[int, int],
    estimator: DisturbanceEstimator,
    plain: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray],
    zones: tuple[np.ndarray, np.ndarray, np.ndarray],
    n_disturbances: int = 0,
) -> ZoneQp:
    """The QP of the plain controller extended by the soft zones of the limited outputs.

    Parameters
    ----------
    ss : StateSpace
        The model's realization (inputs, then DVs).
    horizons : (int, int)
        Np and Nc [samples].
    estimator : DisturbanceEstimator
        Which outputs have a slope.
    plain : (hessian, gradient, gradient_offset, constraints)
        The plain QP (:class:`~pmr_ros.core.mpc.design.CondensedQp` and its constraint rows).
    zones : (low, high, weight)
        Per output: limits [output unit] (``-inf``/``inf``: none) and zone weight; only outputs
        with a finite limit are checked.
    n_disturbances : int
        DV columns at the end of ``ss.B``.
    """
    hessian, gradient, offset, constraints = plain
    low, high, weight = (np.asarray(a, dtype=float) for a in zones)
    n_out = ss.C.shape[0]
    rows_out = np.flatnonzero(np.isfinite(low) | np.isfinite(high))
    points = zone_points(horizons[0])
    rows = ((points[:, None] - 1) * n_out + rows_out[None, :]).ravel()  # point-major
    free, Theta = _prediction_rows(ss, horizons=horizons, estimator=estimator, n_disturbances=n_disturbances)
    P, T = free[rows], Theta[rows]
    w = np.tile(weight[rows_out], points.size)
    n_moves, n_t = hessian.shape[0], rows.size
    WT = w[:, None] * T
    big_h = np.block([[hessian + T.T @ WT, -WT.T], [-WT, np.diag(w)]])
    big_g = np.vstack([gradient + WT.T @ P, -w[:, None] * P])
    big_c = np.block([[constraints, np.zeros((constraints.shape[0], n_t))], [np.zeros((n_t, n_moves)), np.eye(n_t)]])
    return ZoneQp(
        hessian=0.5 * (big_h + big_h.T),
        gradient=big_g,
        gradient_offset=np.concatenate([offset, np.zeros(n_t)]),
        constraints=big_c,
        low=np.tile(low[rows_out], points.size),
        high=np.tile(high[rows_out], points.size),
        prediction=P,
        moves=T,
    )


class ZoneTarget:
    """The input target of the steady state that meets the setpoints and keeps the stable limited CVs in their zones.

    The controller's input-target penalty pulls the inputs, along the freedom
    the setpoints leave (the null space ``N`` of the tracked steady-state
    gain), towards ``u_target``; a zone CV is free there, so the pull may take
    it out of its zone, against the zone's soft penalty.  Each step this
    target calculation moves the target to the steady state nearest
    ``u_target`` (S-norm) among those that meet the setpoints (least squares)
    and keep every stable limited CV inside its zone -- a small QP in the
    free coordinates ``alpha``, ``u = u_sp + N alpha``.  Priorities: the
    setpoints, then the zones, then the input targets.  When no zone binds
    the penalty is unchanged (``M u_target`` is the same), so the controller
    is the plain one; when the zones cannot be met with the setpoints, the
    configured target stands and the soft penalty over the horizon decides.

    Parameters
    ----------
    tracked_gain : ndarray, shape (n_outputs, n_inputs)
        The steady-state gain of what the setpoints fix (a stable zone CV's row zero).
    steady_gain : ndarray, shape (n_outputs, n_inputs)
        :func:`~pmr_ros.core.mpc.design.steady_state_gain`.
    integrating : ndarray of bool, shape (n_outputs,)
        The integrating outputs (their steady state: the rate ``-p``).
    zones : (low, high)
        Per output [output unit].
    weight, input_target : ndarray, shape (n_inputs,)
        ``S`` and ``u_target``.
    """

    def __init__(
        self,
        *,
        tracked_gain: np.ndarray,
        steady_gain: np.ndarray,
        integrating: np.ndarray,
        zones: tuple[np.ndarray, np.ndarray],
        weight: np.ndarray,
        input_target: np.ndarray,
    ) -> None:
        low, high = (np.asarray(a, dtype=float) for a in zones)
        self._integrating = np.asarray(integrating, dtype=bool)
        self._fixed = np.any(tracked_gain != 0, axis=1) & ~self._integrating  # stable setpoint rows: r - d
        self._pinv = np.linalg.pinv(tracked_gain)
        self._free = null_space(tracked_gain)
        self._rows = np.flatnonzero((np.isfinite(low) | np.isfinite(high)) & ~self._integrating)
        self._gain = steady_gain[self._rows]
        self._low, self._high = low[self._rows], high[self._rows]
        self._target, self._weight = np.asarray(input_target, dtype=float), np.asarray(weight, dtype=float)
        self._qp: DenseQp | None = None
        if self._free.shape[1] and self._rows.size:
            sn = self._weight[:, None] * self._free
            self._qp = DenseQp(self._free.T @ sn, self._gain @ self._free)

    def input_target(self, setpoint: np.ndarray, step: np.ndarray, slope: np.ndarray) -> np.ndarray:
        """The zone-respecting input target for setpoints ``r``, step estimates ``d`` and slopes ``p``."""
        if self._qp is None:
            return self._target
        b = np.zeros(step.shape[0])
        b[self._fixed] = (setpoint - step)[self._fixed]
        b[self._integrating] = -slope
        u_sp = self._pinv @ b
        q = self._free.T @ (self._weight * (u_sp - self._target))
        base = step[self._rows] + self._gain @ u_sp
        solution = self._qp.solve(q, lower=self._low - base, upper=self._high - base)
        if not solution.solved:  # setpoints and zones cannot both be met: the horizon's soft penalty decides
            return self._target
        return u_sp + self._free @ solution.x
