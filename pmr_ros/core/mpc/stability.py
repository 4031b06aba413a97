"""Stability of the unconstrained MPC loop: its state matrix and spectral radius.

With no limit active :class:`~pmr_ros.core.mpc.controller.LinearMpc` is a linear
controller, and the loop of plant, controller model, previous input and
disturbance estimates is ``s+ = M s`` with
``s = [x_plant; x_model; u_prev; d_int; p_int]`` (``d_int``, ``p_int`` the step
and slope estimates of the integrating outputs; a stable output's step is
recomputed each sample and holds no memory).  The loop is stable iff every
eigenvalue of ``M`` that shows in the signals lies inside the unit circle.

Integrating elements bring eigenvalues at exactly 1 that never show:
a controller-model integrator offset by ``delta`` together with its output's
step estimate offset by ``-delta`` (the two cancel in every prediction), and,
in a plant row with several integrators, one integrator up and another down
by the same amount (the output reads their sum).  These neutral modes are
invariant directions of ``M``; the spectral radius is taken on the rest.
"""

from __future__ import annotations

import numpy as np
import scipy.linalg

from ..sim.model import TransferMatrix
from .controller import LinearMpc

__all__ = ["closed_loop_matrix", "loop_spectral_radius", "neutral_modes"]


def closed_loop_matrix(controller: LinearMpc, plant: TransferMatrix) -> np.ndarray:
    """``M`` of the unconstrained loop ``s+ = M s`` (setpoints, input targets and measured disturbances at zero).

    Parameters
    ----------
    controller : LinearMpc
        The controller (its model, tuning and disturbance model).
    plant : TransferMatrix
        The true plant ``G`` (same inputs and outputs as the controller's model).

    Returns
    -------
    ndarray, shape (n_s, n_s)
        ``n_s = nx_plant + nx_model + n_in + 2 n_ramps``.
    """
    p, m = plant.state_space(), controller.matrices
    est = controller.estimator
    npx, nmx, n_in, n_out, nr = p.A.shape[0], m.A.shape[0], controller.model.n_inputs, m.C.shape[0], est.n_ramps
    held = nmx + n_in + controller.n_disturbances  # z's DVs (external, zero here) sit after u_prev
    n_s = npx + nmx + n_in + 2 * nr
    blocks = np.cumsum([0, npx, nmx, n_in, nr, nr])
    xp, xm, up, dr, pr = (slice(blocks[j], blocks[j + 1]) for j in range(5))
    residual = np.zeros((n_out, n_s))  # e = C_p x_p - C_m x_m
    residual[:, xp], residual[:, xm] = p.C, -m.C
    step = residual.copy()  # stable outputs: d = e
    innovation = residual[est.integrating].copy()  # e - (d + p) on the integrating outputs
    innovation[:, dr] -= np.eye(nr)
    innovation[:, pr] -= np.eye(nr)
    step[est.integrating] = est.alpha * innovation
    step[est.integrating, dr] += np.eye(nr)
    step[est.integrating, pr] += np.eye(nr)
    slope = est.beta * innovation
    slope[:, pr] += np.eye(nr)
    z = np.zeros((m.gain.shape[1], n_s))  # z = [x_m; u_prev; v = 0; r = 0; d; p]
    z[:nmx, xm] = np.eye(nmx)
    z[nmx : nmx + n_in, up] = np.eye(n_in)
    z[held + n_out : held + 2 * n_out] = step
    z[held + 2 * n_out :] = slope
    u = m.gain[:n_in] @ z
    u[:, up] += np.eye(n_in)
    M = np.zeros((n_s, n_s))
    M[xp] = p.B @ u
    M[xp, xp] += p.A
    M[xm] = m.B[:, :n_in] @ u
    M[xm, xm] += m.A
    M[up] = u
    M[dr] = step[est.integrating]
    M[pr] = slope
    return M


def neutral_modes(controller: LinearMpc, plant: TransferMatrix) -> np.ndarray:
    """The loop's neutral directions (eigenvalue 1, invisible in u and y), one per column.

    Parameters
    ----------
    controller : LinearMpc
    plant : TransferMatrix

    Returns
    -------
    ndarray, shape (n_s, n_neutral)
        In the coordinates of :func:`closed_loop_matrix`.
    """
    p = plant.state_space()
    npx = p.A.shape[0]
    m = controller.matrices
    nmx = m.A.shape[0]
    n_in, n_ramps = controller.model.n_inputs, controller.estimator.n_ramps
    n_s = npx + nmx + n_in + 2 * n_ramps
    if controller.model.has_general or plant.has_general:
        return _general_neutral_modes((p.A, p.C), (m.A, m.C), controller.estimator.integrating, n_s)
    ramp_of_row = {int(i): j for j, i in enumerate(controller.estimator.integrating)}
    pairs = [  # a controller-model integrator up, its output's step estimate down
        (npx + state, npx + nmx + n_in + ramp_of_row[row]) for state, row in _integrator_states(controller.model)
    ]
    plant_states = _integrator_states(plant)
    for i in range(plant.n_outputs):  # two plant integrators of one output, one up, one down
        states = [state for state, row in plant_states if row == i]
        pairs.extend((states[0], other) for other in states[1:])
    columns = np.zeros((n_s, len(pairs)))
    for c, (up, down) in enumerate(pairs):
        columns[up, c], columns[down, c] = 1.0, -1.0
    return columns


NEUTRAL_RCOND = 1e-9
"""Relative singular value below which ``A - I`` is taken as singular: a sampled integrator's pole is 1 to round-off."""


def _general_neutral_modes(
    plant: tuple[np.ndarray, np.ndarray], model: tuple[np.ndarray, np.ndarray], ramp_rows: np.ndarray, n_s: int
) -> np.ndarray:
    """:func:`neutral_modes` of realizations of any order, from their invariant directions at eigenvalue 1.

    A plant direction ``v`` with ``A_p v = v`` and ``C_p v = 0`` (integrators of
    one output that cancel) never shows; a controller-model direction
    ``A_m v = v`` shows as ``C_m v`` in the prediction, which the step
    estimates of the integrating outputs offset by ``-C_m v``.
    """
    (ap, cp), (am, cm) = plant, model
    npx, nmx = ap.shape[0], am.shape[0]
    hidden = scipy.linalg.null_space(np.vstack([ap - np.eye(npx), cp]), rcond=NEUTRAL_RCOND)
    shown = scipy.linalg.null_space(am - np.eye(nmx), rcond=NEUTRAL_RCOND)
    columns = np.zeros((n_s, hidden.shape[1] + shown.shape[1]))
    columns[:npx, : hidden.shape[1]] = hidden
    steps = n_s - 2 * len(ramp_rows)  # the step estimates of the integrating outputs start here
    columns[npx : npx + nmx, hidden.shape[1] :] = shown
    columns[steps : steps + len(ramp_rows), hidden.shape[1] :] = -(cm @ shown)[np.asarray(ramp_rows, dtype=int)]
    return columns


def _integrator_states(model: TransferMatrix) -> list[tuple[int, int]]:
    """``(state, row)`` of each integrating element's state (states are the present elements, row-major)."""
    rows, cols = np.nonzero(model.present)
    return [(s, int(i)) for s, (i, k) in enumerate(zip(rows, cols, strict=True)) if model.integrating[i, k]]


def loop_spectral_radius(controller: LinearMpc, plant: TransferMatrix) -> float:
    """Largest eigenvalue magnitude of the unconstrained loop, neutral modes left out; < 1 is stable.

    Parameters
    ----------
    controller : LinearMpc
    plant : TransferMatrix

    Returns
    -------
    float
    """
    M = closed_loop_matrix(controller, plant)
    neutral = neutral_modes(controller, plant)
    if neutral.shape[1]:
        # M maps span(neutral) into itself; its other eigenvalues are those of M on the complement.
        rest = scipy.linalg.null_space(neutral.T)
        M = rest.T @ M @ rest
    return float(np.abs(np.linalg.eigvals(M)).max())
