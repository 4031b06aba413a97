"""Offline design of the MPC: predictions, steady state, where extra MVs rest, the condensed QP.

Everything here is computed once, when a controller is built; a step is then
one matrix-vector product (:class:`~pmr_ros.core.mpc.controller.LinearMpc`).

**The steady state** of a model is what its outputs do when the inputs are
held: a stable output settles to ``G_ss u + d`` (``G_ss`` the FOPTD gains), an
integrating output keeps changing at the rate ``Ts K_int u + p`` per sample
(``K_int`` its integrating elements' gains).  ``steady_state_gain`` stacks both
kinds of row; a steady state needs the stable rows at their setpoints and the
integrating rows' rates at zero -- the level itself reaches its setpoint in the
transient, any level is a steady state.

**More inputs than outputs** (more MVs than CVs): the steady state leaves the
inputs free along the null space of ``G_ss``; without a say there the inputs
wander along it (moves cost, positions do not) until they hit their limits.
The freedom is spent with **input targets** (ideal resting values)
``u_target`` and weights ``S`` per input: of all steady states that meet the
setpoints the controller heads for the one nearest ``u_target`` in the
``S``-norm.  It penalises ``(u - u_target)' M (u - u_target)`` on the input
path with ``M = S N (N' S N)^-1 N' S``, ``N`` a basis of the null space: ``M``
vanishes on every direction a setpoint needs (``S^-1 G_ss'``), so the term never
costs tracking, and it is zero exactly at that nearest steady state.  A square
system has no null space, ``M = 0``: the controller is the plain one.

**More outputs than inputs**, or collinear rows: not every setpoint can be met.
A target calculation replaces the setpoints by the nearest reachable outputs
``y_s``: the integrating rows' rates are held at zero (a level that keeps
ramping is not a compromise), and the stable rows are met in the least-squares
sense weighted by the output weights ``Q``.  ``y_s`` is linear in the setpoints
and disturbance estimates, so it folds into the controller's gain.  When every
setpoint is reachable (``G_ss`` has full row rank) ``y_s = r``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from ..sim.model import StateSpace, TransferMatrix
from .estimator import DisturbanceEstimator

__all__ = [
    "CondensedQp",
    "QpWeights",
    "condensed_qp",
    "input_target_penalty",
    "null_space",
    "prediction_matrices",
    "setpoints_reachable",
    "split_disturbances",
    "steady_state_gain",
    "target_map",
]


def prediction_matrices(
    ss: StateSpace, *, prediction_horizon: int, control_horizon: int
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The condensed predictions ``Phi``, ``Psi``, ``Theta`` of a model over the horizons.

    ``yhat(k+1..k+Np) = Phi x(k) + Psi u(k-1) + Theta dU`` with ``dU`` the
    moves of the control horizon (the input held after it).  The powers of
    ``A`` are applied to ``B`` and ``C`` (all sparse), never formed.

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
    A, C = sp.csr_matrix(ss.A), sp.csr_matrix(ss.C)  # both sparse: a state per element, a register per delay
    Np, Nc = prediction_horizon, control_horizon
    n_out, n_in = ss.C.shape[0], ss.B.shape[1]
    step = np.empty((Np, n_out, n_in))  # step[j] = sum_{t<=j} C A^t B
    Phi = np.empty((Np * n_out, ss.A.shape[0]))
    a_power_b, c_a_power = ss.B.copy(), ss.C.copy()  # A^j B, C A^j
    acc = np.zeros((n_out, n_in))
    for j in range(Np):
        acc = acc + C @ a_power_b
        step[j] = acc
        a_power_b = A @ a_power_b
        c_a_power = np.asarray((A.T @ c_a_power.T).T)
        Phi[j * n_out : (j + 1) * n_out] = c_a_power
    Psi = step.reshape(Np * n_out, n_in)
    Theta = np.zeros((Np * n_out, Nc * n_in))
    for j in range(Np):
        for m in range(min(j + 1, Nc)):
            Theta[j * n_out : (j + 1) * n_out, m * n_in : (m + 1) * n_in] = step[j - m]
    return Phi, Psi.copy(), Theta


def steady_state_gain(model: TransferMatrix) -> np.ndarray:
    """Steady-state map of the inputs, shape (n_outputs, n_inputs).

    A stable output's row holds its elements' steady-state gains (its settled
    value per unit input: K of a FOPTD element, ``num(0)/den(0)`` of a tf, the
    settled end of a step-response curve); an integrating output's row holds
    ``Ts K`` of its integrating elements (its rate per sample per unit input,
    K a ramp rate per time unit); empty cells are 0.
    """
    stable = np.where(model.present & ~model.integrating, model.gain, 0.0)
    rate = np.where(model.integrating, model.gain * model.sample_time, 0.0)
    return np.where(model.integrating_outputs[:, None], rate, stable)


def null_space(matrix: np.ndarray) -> np.ndarray:
    """Orthonormal basis of the null space of ``matrix`` (columns), rank by numpy's default tolerance."""
    matrix = np.atleast_2d(matrix)
    n = matrix.shape[1]
    if matrix.shape[0] == 0:
        return np.eye(n)
    _, sigma, vh = np.linalg.svd(matrix)
    rank = int(np.sum(sigma > sigma.max(initial=0.0) * max(matrix.shape) * np.finfo(float).eps))
    return vh[rank:].T.copy()


def input_target_penalty(steady_gain: np.ndarray, weight: np.ndarray) -> np.ndarray:
    """``M = S N (N' S N)^-1 N' S``: the input-target penalty on the steady state's free directions.

    Parameters
    ----------
    steady_gain : ndarray, shape (n_outputs, n_inputs)
        :func:`steady_state_gain`.
    weight : ndarray, shape (n_inputs,)
        ``S``: input-target weight per input [1/input unit^2], > 0.

    Returns
    -------
    ndarray, shape (n_inputs, n_inputs)
        Zero when the steady state leaves the inputs no freedom.
    """
    free = null_space(steady_gain)
    n_in = steady_gain.shape[1]
    if free.shape[1] == 0:
        return np.zeros((n_in, n_in))
    weighted = np.asarray(weight, dtype=float)[:, None] * free  # S N
    return weighted @ np.linalg.solve(free.T @ weighted, weighted.T)


def setpoints_reachable(steady_gain: np.ndarray) -> bool:
    """Whether every setpoint can be met at steady state (``G_ss`` has full row rank)."""
    return null_space(steady_gain.T).shape[1] == 0


def target_map(steady_gain: np.ndarray, integrating: np.ndarray, output_weight: np.ndarray) -> np.ndarray:
    """The map ``F`` of ``[r; d; p]`` to the tracked offset ``y_s - d`` (the target calculation).

    Parameters
    ----------
    steady_gain : ndarray, shape (n_outputs, n_inputs)
        :func:`steady_state_gain`.
    integrating : ndarray of bool, shape (n_outputs,)
        The integrating outputs.
    output_weight : ndarray, shape (n_outputs,)
        ``Q``: weights of the least-squares compromise between stable outputs.

    Returns
    -------
    ndarray, shape (n_outputs, 2 n_outputs + n_integrating)
        ``y_s - d = F [r; d; p]``, ``p`` the slopes of the integrating outputs.
        ``[I, -I, 0]`` when every setpoint is reachable.
    """
    n_out, n_in = steady_gain.shape
    ramps = np.flatnonzero(integrating)
    stable = np.flatnonzero(~np.asarray(integrating))
    F = np.zeros((n_out, 2 * n_out + ramps.size))
    F[ramps, ramps] = 1.0  # a level's setpoint is reached in the transient: y_s = r
    F[ramps, n_out + ramps] = -1.0
    if setpoints_reachable(steady_gain):
        F[stable, stable] = 1.0
        F[stable, n_out + stable] = -1.0
        return F
    g_int, g_stable = steady_gain[ramps], steady_gain[stable]
    rate_inverse = -np.linalg.pinv(g_int) if ramps.size else np.zeros((n_in, 0))  # u_p = rate_inverse p
    free = null_space(g_int)
    w = np.sqrt(np.asarray(output_weight, dtype=float)[stable])
    fit = free @ np.linalg.pinv(w[:, None] * (g_stable @ free)) * w  # u_s = u_p + fit (r_S - d_S - G_S u_p)
    u_of_r, u_of_d = fit, -fit
    u_of_p = rate_inverse - fit @ g_stable @ rate_inverse
    F[np.ix_(stable, stable)] = g_stable @ u_of_r  # y_s - d = G_S u_s on the stable rows
    F[np.ix_(stable, n_out + stable)] = g_stable @ u_of_d
    F[stable, 2 * n_out :] = g_stable @ u_of_p
    return F


def split_disturbances(
    Psi: np.ndarray, Theta: np.ndarray, *, n_inputs: int, control_horizon: int
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The inputs' ``Psi``, ``Theta`` and the disturbances' ``Psi_v`` of a model whose last columns are DVs.

    A DV has no moves to decide: its columns leave ``Theta``, and its held
    value acts through its column of ``Psi``.  Without DVs the arrays pass through.
    """
    n_total = Psi.shape[1]
    if n_total == n_inputs:
        return Psi, Psi[:, n_inputs:], Theta
    columns = (np.arange(control_horizon)[:, None] * n_total + np.arange(n_inputs)).ravel()
    return Psi[:, :n_inputs].copy(), Psi[:, n_inputs:].copy(), Theta[:, columns]


@dataclass(frozen=True)
class CondensedQp:
    """The MPC's QP over the moves ``dU`` of the control horizon, with its inputs stacked in ``z``.

    ``z = [x; u_prev; v; r; d; p]``: model state, previous input, measured
    disturbances (DVs, held over the horizon; none without a DV model),
    setpoints, output-step and slope estimates.  The QP is
    ``min dU' H dU / 2 + q' dU`` with ``q = gradient @ z + gradient_offset``.

    Attributes
    ----------
    hessian : ndarray, shape (Nc*n_in, Nc*n_in)
    gradient : ndarray, shape (Nc*n_in, nz)
    gradient_offset : ndarray, shape (Nc*n_in,)
        From the input targets.
    cumulative : ndarray, shape (Nc*n_in, Nc*n_in)
        Moves to input path: ``u_path = tile(u_prev) + cumulative @ dU``.
    target_gradient : ndarray, shape (Nc*n_in, n_in)
        ``gradient_offset`` per unit of input target: ``gradient_offset = target_gradient @ input_target``
        (a target computed each step, as with CV zones, enters through it).
    """

    hessian: np.ndarray
    gradient: np.ndarray
    gradient_offset: np.ndarray
    cumulative: np.ndarray
    target_gradient: np.ndarray


@dataclass(frozen=True)
class QpWeights:
    """The weights and targets of the QP, per channel (see :class:`~pmr_ros.core.mpc.controller.MpcTuning`)."""

    output: np.ndarray
    move: np.ndarray
    input_target: np.ndarray
    input_target_penalty: np.ndarray


def condensed_qp(
    ss: StateSpace,
    *,
    horizons: tuple[int, int],
    weights: QpWeights,
    targets: np.ndarray,
    estimator: DisturbanceEstimator,
    n_disturbances: int = 0,
) -> CondensedQp:
    """Build the condensed QP of the tracking, move and input-target costs.

    The predicted outputs are ``Phi x + Psi u_prev + Psi_v v + Theta dU`` plus
    the disturbance ``d + j p`` (``p`` on integrating outputs); they are held to
    ``y_s`` (``y_s - d = targets @ [r; d; p]``).  ``v`` are the measured
    disturbances, held at their current value over the horizon (feedforward).

    Parameters
    ----------
    ss : StateSpace
        The model's realization.
    horizons : (int, int)
        Np and Nc [samples].
    weights : QpWeights
    targets : ndarray
        :func:`target_map`.
    estimator : DisturbanceEstimator
        Which outputs have a slope.
    n_disturbances : int
        The last columns of ``ss.B`` that are measured disturbances, not inputs.
    """
    Np, Nc = horizons
    n_out, n_in = ss.C.shape[0], ss.B.shape[1] - n_disturbances
    Phi, Psi, Theta = prediction_matrices(ss, prediction_horizon=Np, control_horizon=Nc)
    Psi, Psi_v, Theta = split_disturbances(Psi, Theta, n_inputs=n_in, control_horizon=Nc)
    W = (Theta * np.tile(weights.output, Np)[:, None]).T  # Theta' Q
    cumulative = np.kron(np.tril(np.ones((Nc, Nc))), np.eye(n_in))
    penalty = np.kron(np.eye(Nc), weights.input_target_penalty)
    hessian = W @ Theta + np.diag(np.tile(weights.move, Nc)) + cumulative.T @ penalty @ cumulative
    hold = cumulative.T @ penalty @ np.tile(np.eye(n_in), (Nc, 1))  # L' M tile(.)
    ramp = np.kron(np.arange(1.0, Np + 1.0)[:, None], np.eye(n_out)[:, estimator.integrating])
    to_target = -W.reshape(-1, Np, n_out).sum(axis=1) @ targets
    to_target[:, 2 * n_out :] += W @ ramp
    gradient = np.hstack([W @ Phi, W @ Psi + hold, *([W @ Psi_v] if n_disturbances else []), to_target])
    return CondensedQp(0.5 * (hessian + hessian.T), gradient, -hold @ weights.input_target, cumulative, -hold)
