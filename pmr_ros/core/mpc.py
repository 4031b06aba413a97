"""Linear constrained MPC on OSQP with offset-free output-bias correction.

The controller predicts with its model ``Ghat`` (the state-space realization of
the FOPTD matrix, delays as shift registers), penalizes tracking error and
input moves, and respects input magnitude and rate limits.  The QP is posed in
the condensed form over the input moves ``dU`` of the control horizon:

    min  (Yfree + Theta dU - Rtarget)' Q (...) + dU' R dU
    s.t. u_min <= u_prev + L dU <= u_max,  |dU| <= du_max

so its Hessian and constraint matrix never change: OSQP factors them once and
each step only the linear term and the bounds are updated (warm-started).
When the unconstrained minimizer ``-H^-1 q`` satisfies every constraint it is
the QP's solution, so it is used directly and OSQP runs only when a limit
would bind; ``statistics`` counts how often.
Offset-free tracking uses the DMC/IMC output-disturbance bias
``d = y_measured - yhat`` held constant over the horizon.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np
import osqp
import scipy.sparse as sp

from .foptd import FoptdMatrix, StateSpace


@dataclass(frozen=True)
class MpcTuning:
    """MPC tuning.

    Attributes
    ----------
    prediction_horizon : int
        Np [samples]; must cover the largest delay plus the settling of interest.
    control_horizon : int
        Nc [samples] of free moves; the input is held after it.
    output_weight : ndarray, shape (n_outputs,)
        Q, per output, on squared tracking error [1/output unit^2].
    move_weight : ndarray, shape (n_inputs,)
        R, per input, on squared moves [1/input unit^2].
    u_min, u_max : ndarray, shape (n_inputs,)
        Input magnitude limits [input unit], in deviation from nominal.
    du_max : ndarray, shape (n_inputs,)
        Largest move per sample [input unit].
    """

    prediction_horizon: int
    control_horizon: int
    output_weight: np.ndarray
    move_weight: np.ndarray
    u_min: np.ndarray
    u_max: np.ndarray
    du_max: np.ndarray


@dataclass(frozen=True)
class MpcMatrices:
    """Read-only view of the matrices a :class:`LinearMpc` computes with.

    For code that evaluates the same controller for many runs at once (the
    lockstep batch simulator) or analyses the closed loop.  Shapes use
    ``nx`` model states, ``Np`` prediction and ``Nc`` control horizon.

    Attributes
    ----------
    A, B, C : ndarray
        The model's realization ``x+ = A x + B u``, ``yhat = C x``.
    free_state : ndarray, shape (Np*n_out, nx)
        ``Phi``: the predicted outputs' dependence on the model state.
    free_input : ndarray, shape (Np*n_out, n_in)
        ``Psi``: their dependence on holding the previous input.
    weighted_dynamic : ndarray, shape (Nc*n_in, Np*n_out)
        ``Theta' Q``: the QP's linear term is ``q = -Theta' Q (target - free)``.
    unconstrained_gain : ndarray, shape (Nc*n_in, Nc*n_in)
        ``-H^-1``: the unconstrained optimum is ``dU* = unconstrained_gain @ q``.
    cumulative : ndarray, shape (Nc*n_in, Nc*n_in)
        Moves to input path: ``u_path = tile(u_prev) + cumulative @ dU``.
    du_bound, u_min_path, u_max_path : ndarray, shape (Nc*n_in,)
        Move and magnitude limits tiled over the control horizon.
    """

    A: np.ndarray
    B: np.ndarray
    C: np.ndarray
    free_state: np.ndarray
    free_input: np.ndarray
    weighted_dynamic: np.ndarray
    unconstrained_gain: np.ndarray
    cumulative: np.ndarray
    du_bound: np.ndarray
    u_min_path: np.ndarray
    u_max_path: np.ndarray


@dataclass
class MpcStatistics:
    """Counters of the QP solves, for benchmarks and health reporting."""

    steps: int = 0
    solves: int = 0
    failures: int = 0
    solve_time_s: list[float] | None = None


def prediction_matrices(
    ss: StateSpace, *, prediction_horizon: int, control_horizon: int
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The condensed predictions ``Phi``, ``Psi``, ``Theta`` of a model over the horizons.

    ``yhat(k+1..k+Np) = Phi x(k) + Psi u(k-1) + Theta dU`` with ``dU`` the
    moves of the control horizon (the input held after it).

    Parameters
    ----------
    ss : StateSpace
        The model's realization.
    prediction_horizon, control_horizon : int
        Np and Nc [samples].

    Returns
    -------
    Phi : ndarray, shape (Np*n_out, nx)
        Effect of the current state.
    Psi : ndarray, shape (Np*n_out, n_in)
        Effect of holding the previous input.
    Theta : ndarray, shape (Np*n_out, Nc*n_in)
        Effect of the moves: block (j, m) is the step response ``S_(j-m)``.
    """
    A, B, C = ss.A, ss.B, ss.C
    Np, Nc = prediction_horizon, control_horizon
    n_out, n_in, nx = C.shape[0], B.shape[1], A.shape[0]
    markov = []  # C A^j B, j = 0..Np-1
    Apow = np.eye(nx)
    for _ in range(Np):
        markov.append(C @ Apow @ B)
        Apow = A @ Apow
    Phi = np.zeros((Np * n_out, nx))
    Psi = np.zeros((Np * n_out, n_in))
    Apow = np.eye(nx)
    acc = np.zeros((n_out, n_in))
    for j in range(Np):
        Apow = A @ Apow  # A^(j+1)
        Phi[j * n_out : (j + 1) * n_out] = C @ Apow
        acc = acc + markov[j]
        Psi[j * n_out : (j + 1) * n_out] = acc
    step = np.cumsum(np.stack(markov), axis=0)  # step[j] = sum_{t<=j} C A^t B
    Theta = np.zeros((Np * n_out, Nc * n_in))
    for j in range(Np):
        for m in range(min(j + 1, Nc)):
            Theta[j * n_out : (j + 1) * n_out, m * n_in : (m + 1) * n_in] = step[j - m]
    return Phi, Psi, Theta


class LinearMpc:
    """Constrained MPC for a FOPTD matrix model.

    Parameters
    ----------
    model : FoptdMatrix
        The controller's model ``Ghat`` (deviation variables).
    tuning : MpcTuning
    record_solve_times : bool
        Keep each OSQP solve's wall time in ``statistics.solve_time_s``.
    always_solve_qp : bool
        Call OSQP every step, even when no constraint binds (for benchmarks
        and for checking the unconstrained shortcut).
    """

    def __init__(
        self, model: FoptdMatrix, tuning: MpcTuning, *, record_solve_times: bool = False, always_solve_qp: bool = False
    ) -> None:
        self.model = model
        self.always_solve_qp = always_solve_qp
        self.tuning = tuning
        ss = model.state_space()
        self._A, self._B, self._C = ss.A, ss.B, ss.C
        Np, Nc = tuning.prediction_horizon, tuning.control_horizon
        if Nc > Np:
            raise ValueError("control_horizon must not exceed prediction_horizon")
        self._Phi, self._Psi, self._Theta = prediction_matrices(ss, prediction_horizon=Np, control_horizon=Nc)
        n_in = model.n_inputs
        Q = np.tile(np.asarray(tuning.output_weight, dtype=float), Np)
        R = np.tile(np.asarray(tuning.move_weight, dtype=float), Nc)
        self._QTheta_T = (self._Theta * Q[:, None]).T  # Theta' Q
        H = self._QTheta_T @ self._Theta + np.diag(R)
        H = 0.5 * (H + H.T)
        self._cumulative = np.kron(np.tril(np.ones((Nc, Nc))), np.eye(n_in))
        self._du_bound = np.tile(np.asarray(tuning.du_max, dtype=float), Nc)
        self._u_min = np.tile(np.asarray(tuning.u_min, dtype=float), Nc)
        self._u_max = np.tile(np.asarray(tuning.u_max, dtype=float), Nc)
        self._unconstrained = -np.linalg.solve(H, np.eye(H.shape[0]))  # dU* = this @ q
        self._solver = self._setup_solver(H)
        self.statistics = MpcStatistics(solve_time_s=[] if record_solve_times else None)
        self.reset()

    def _setup_solver(self, H: np.ndarray) -> osqp.OSQP:
        """OSQP with the fixed Hessian and constraint matrix, factored once."""
        n_moves = H.shape[0]
        A_con = sp.vstack([sp.csc_matrix(self._cumulative), sp.identity(n_moves, format="csc")], format="csc")
        solver = osqp.OSQP()
        solver.setup(
            sp.triu(sp.csc_matrix(H), format="csc"),
            np.zeros(n_moves),
            A_con,
            np.concatenate([self._u_min, -self._du_bound]),
            np.concatenate([self._u_max, self._du_bound]),
            verbose=False,
            warm_starting=True,
            eps_abs=1e-7,
            eps_rel=1e-7,
            max_iter=10000,
            polishing=False,
        )
        return solver

    def reset(self) -> None:
        """Forget the model state and past input (plant at rest)."""
        self._x = np.zeros(self._A.shape[0])
        self._u_prev = np.zeros(self.model.n_inputs)

    @property
    def matrices(self) -> MpcMatrices:
        """The controller's matrices as read-only copies (see :class:`MpcMatrices`)."""

        def frozen(a: np.ndarray) -> np.ndarray:
            out = np.array(a, dtype=float, copy=True)
            out.flags.writeable = False
            return out

        return MpcMatrices(
            A=frozen(self._A),
            B=frozen(self._B),
            C=frozen(self._C),
            free_state=frozen(self._Phi),
            free_input=frozen(self._Psi),
            weighted_dynamic=frozen(self._QTheta_T),
            unconstrained_gain=frozen(self._unconstrained),
            cumulative=frozen(self._cumulative),
            du_bound=frozen(self._du_bound),
            u_min_path=frozen(self._u_min),
            u_max_path=frozen(self._u_max),
        )

    @property
    def model_output(self) -> np.ndarray:
        """The model's prediction ``yhat(k)`` of the current output [output unit]."""
        return self._C @ self._x

    def step(self, y_measured, setpoint) -> np.ndarray:
        """Compute ``u(k)`` from ``y(k)`` and ``r(k)``; advance the internal model.

        Parameters
        ----------
        y_measured : array_like, shape (n_outputs,)
            Measured outputs [output unit].
        setpoint : array_like, shape (n_outputs,)
            Setpoints [output unit], held over the horizon.

        Returns
        -------
        ndarray, shape (n_inputs,)
            The input to apply over the next sample [input unit].
        """
        y_measured = np.asarray(y_measured, dtype=float)
        bias = y_measured - self._C @ self._x
        target = np.tile(np.asarray(setpoint, dtype=float) - bias, self.tuning.prediction_horizon)
        free = self._Phi @ self._x + self._Psi @ self._u_prev
        q = -self._QTheta_T @ (target - free)
        u_rep = np.tile(self._u_prev, self.tuning.control_horizon)
        stats = self.statistics
        stats.steps += 1
        moves = self._unconstrained @ q
        u_path = u_rep + self._cumulative @ moves
        feasible = np.all(np.abs(moves) <= self._du_bound) and np.all((u_path >= self._u_min) & (u_path <= self._u_max))
        if feasible and not self.always_solve_qp:
            move = moves[: self.model.n_inputs]
        else:
            lower = np.concatenate([self._u_min - u_rep, -self._du_bound])
            upper = np.concatenate([self._u_max - u_rep, self._du_bound])
            move = self.solve_constrained(q, lower=lower, upper=upper)
        n_in = self.model.n_inputs
        u = np.clip(
            self._u_prev + np.clip(move, -self._du_bound[:n_in], self._du_bound[:n_in]),
            self.tuning.u_min,
            self.tuning.u_max,
        )
        self._x = self._A @ self._x + self._B @ u
        self._u_prev = u
        return u

    def solve_constrained(self, q: np.ndarray, *, lower: np.ndarray, upper: np.ndarray) -> np.ndarray:
        """The first move of the constrained QP for linear term ``q`` and move bounds (OSQP, warm-started).

        Counts the solve in :attr:`statistics`; on a failed solve the input is
        held (a zero move), the safe fallback of industrial MPC.
        """
        self._solver.update(q=q, l=lower, u=upper)
        t0 = time.perf_counter()
        result = self._solver.solve(raise_error=False)
        elapsed = time.perf_counter() - t0
        stats = self.statistics
        stats.solves += 1
        if stats.solve_time_s is not None:
            stats.solve_time_s.append(elapsed)
        n_in = self.model.n_inputs
        if result.info.status_val in (osqp.SolverStatus.OSQP_SOLVED, osqp.SolverStatus.OSQP_SOLVED_INACCURATE):
            return result.x[:n_in]
        # Holding the input is the safe fallback of industrial MPC on a failed solve.
        stats.failures += 1
        return np.zeros(n_in)
