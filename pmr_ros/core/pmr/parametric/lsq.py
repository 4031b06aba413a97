"""Joint weighted least squares of one row's continuous parameters for fixed whole-sample delays.

The coefficient of column k is ``lin_k * shape_k(w; s_k) * z^-d_k``
(:class:`~.ratio.ColumnModel`); with the delays held, the row's cost
``sum_w |b - A theta|^2`` is minimized over the linear parameters ``lin`` and
the log time constants ``s`` by a bounded Levenberg-Marquardt iteration on
the information form (:class:`~.ratio.RowSystem`), whose Gauss-Newton matrix
``Re sum_w dtheta^H M dtheta`` is also the information the covariance inverts.

The time constant of an empty cell's interaction template is held where the
column search (:mod:`.search`) put it: when there is no interaction its gain
is about zero and its time constant is not identifiable at all -- a flat
direction that would only slow the iteration down -- and when there is one
the search has already placed it.
"""

from __future__ import annotations

import copy
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from .ratio import GAIN_RATIO_BOUND, ColumnModel, RowSystem

__all__ = ["Coefficients", "RowParameters", "RowProblem"]

MAX_ITERATIONS = 60
"""Most Levenberg-Marquardt steps of one fit."""

COST_TOLERANCE = 1e-7
"""A fit has converged when a step lowers the cost (a chi-square) by less than this.

Far below anything a verdict reads (delay confidences compare chi-square
differences of order one; parameters are then within 1e-3 of their standard
deviation of the optimum), far above rounding."""


@dataclass(frozen=True)
class RowParameters:
    """One row's parameters.

    Attributes
    ----------
    lin : ndarray, shape (n,)
        Linear parameter per column: ``rho = K/Khat`` of an element, ``gamma`` of an interaction.
    s : ndarray, shape (n,)
        ``log(tau / tau_reference)`` of columns with a time constant, 0 elsewhere.
    delays : ndarray of int, shape (n,)
        ``dD`` of an element, ``D`` of an interaction [samples].
    """

    lin: np.ndarray
    s: np.ndarray
    delays: np.ndarray

    def with_delay(self, k: int, delay: int) -> RowParameters:
        """A copy with column ``k``'s delay replaced."""
        delays = self.delays.copy()
        delays[k] = delay
        return RowParameters(self.lin.copy(), self.s.copy(), delays)


@dataclass(frozen=True)
class Coefficients:
    """The coefficients of a row at given parameters, with their derivatives.

    Attributes
    ----------
    theta : ndarray of complex, shape (F', n)
    d_lin : ndarray of complex, shape (F', n)
        ``d theta_k / d lin_k``.
    d_s : ndarray of complex, shape (F', n)
        ``d theta_k / d s_k`` (0 without a time constant).
    """

    theta: np.ndarray
    d_lin: np.ndarray
    d_s: np.ndarray


class RowProblem:
    """The joint fit of one row's ``lin`` and ``s`` for fixed delays.

    Parameters
    ----------
    system : RowSystem
        The row's whitened equations.
    columns : sequence of ColumnModel
        One per regressor.
    """

    def __init__(self, system: RowSystem, columns: Sequence[ColumnModel]) -> None:
        self.columns = list(columns)
        self.n = len(self.columns)
        self.has_tau = np.array([c.has_tau for c in self.columns], dtype=bool)
        self.tau_reference = np.array([c.tau_reference for c in self.columns])
        self.pole_model = np.array([c.pole_model for c in self.columns])
        bounded = np.array([not c.interaction for c in self.columns])
        self.lin_bounds = (np.where(bounded, -GAIN_RATIO_BOUND, -np.inf), np.where(bounded, GAIN_RATIO_BOUND, np.inf))
        self.s_bounds = (
            np.array([c.s_bounds[0] for c in self.columns]),
            np.array([c.s_bounds[1] for c in self.columns]),
        )
        self.tau_index = np.flatnonzero(self.has_tau)
        self.scaled_index = np.flatnonzero([c.scaled is not None for c in self.columns])
        interaction = np.array([c.interaction for c in self.columns], dtype=bool)
        self.free_tau = np.flatnonzero(self.has_tau & ~interaction)
        self._lowest = min((c.delay_bounds[0] for c in self.columns), default=0)
        highest = max((c.delay_bounds[1] for c in self.columns), default=0)
        self._turns = system.z_inv[:, None] ** np.arange(self._lowest, highest + 1)[None, :]  # z^-d per delay
        # what every fit step on the fitted bins repeats and no parameter changes: the model pole's numerator,
        # its product with (z^-1 - 1), the packed parameters' columns and their block of M (the same numbers)
        z_fitted = system.z_inv[:, None]
        self._numerator = (1 - self.pole_model * z_fitted) / (1 - self.pole_model)
        self._numerator_dz = self._numerator * (z_fitted - 1)
        self._owner = np.concatenate([np.arange(self.n), self.free_tau])
        self._all_tau = bool(self.has_tau.all())  # then the np.where of the shapes below keeps every value
        self._bind(system)

    def _bind(self, system: RowSystem) -> None:
        """Take ``system``: what depends on its moments (the rest depends on its bins and the columns only)."""
        self.system = system
        self._m_owner = system.M[:, self._owner][:, :, self._owner]
        self._gathered: dict[bytes, np.ndarray] = {}

    def with_system(self, system: RowSystem) -> RowProblem:
        """``RowProblem(system, self.columns)``, the same numbers, with what no system changes taken from this one.

        A row's fit builds four problems of its columns on its bins (``system.z_inv``); their columns' arrays
        and delay turns were built four times.  Bins other than this problem's build a new one.
        """
        if not np.array_equal(system.z_inv, self.system.z_inv):
            return RowProblem(system, self.columns)
        other = copy.copy(self)
        other._bind(system)
        return other

    def coefficients(self, params: RowParameters, z_inv: np.ndarray | None = None) -> Coefficients:
        """``theta`` and its derivatives at ``params``, on the fitted bins or at ``z_inv = exp(-j w)``."""
        if z_inv is None:
            z_inv = self.system.z_inv[:, None]
            delay = self._delay_turns(params.delays)
            numerator, numerator_dz = self._numerator, self._numerator_dz
        else:
            z_inv = z_inv[:, None]
            delay = z_inv ** params.delays[None, :]
            numerator = (1 - self.pole_model * z_inv) / (1 - self.pole_model)
            numerator_dz = numerator * (z_inv - 1)
        if self._all_tau:  # the np.where below would keep every value
            tau = self.tau_reference * np.exp(params.s)
            a = np.exp(-1.0 / tau)
        else:
            tau = self.tau_reference * np.exp(np.where(self.has_tau, params.s, 0.0))
            a = np.where(self.has_tau, np.exp(-1.0 / tau), 0.0)
        denominator = 1 - a * z_inv
        shape = (1 - a) * numerator / denominator
        d_shape = numerator_dz / denominator**2 * (a / tau)
        if not self._all_tau:
            shape, d_shape = np.where(self.has_tau, shape, 1.0), np.where(self.has_tau, d_shape, 0.0)
        for c in self.scaled_index:  # a tf/step_response element: its own shape (:mod:`.scaled`)
            scaled, d_scaled = self.columns[c].shapes(z_inv[:, 0], params.s[c : c + 1])
            shape[:, c], d_shape[:, c] = scaled[0], d_scaled[0]
        d_lin = shape * delay
        return Coefficients(params.lin * d_lin, d_lin, params.lin * d_shape * delay)

    def _delay_turns(self, delays: np.ndarray) -> np.ndarray:
        """``z^-d`` of each column's delay on the fitted bins (F', n), gathered once per delay vector (read only).

        A fit's every step and trial holds its delays; the gather of a complex column per column cost a sixth
        of a coefficient evaluation.
        """
        key = delays.tobytes()
        if key not in self._gathered:
            if len(self._gathered) >= 256:  # a row's fit tries some tens of delay vectors
                self._gathered.clear()
            gathered = self._turns[:, delays - self._lowest]
            gathered.flags.writeable = False
            self._gathered[key] = gathered
        return self._gathered[key]

    def _pack(self, params: RowParameters) -> np.ndarray:
        return np.concatenate([params.lin, params.s[self.free_tau]])

    def _unpack(self, x: np.ndarray, start: RowParameters) -> RowParameters:
        s = start.s.copy()
        s[self.free_tau] = x[self.n :]
        return RowParameters(x[: self.n].copy(), s, start.delays)

    def _bounds(self) -> tuple[np.ndarray, np.ndarray]:
        lower = np.concatenate([self.lin_bounds[0], self.s_bounds[0][self.free_tau]])
        upper = np.concatenate([self.lin_bounds[1], self.s_bounds[1][self.free_tau]])
        return lower, upper

    def jacobian(self, coefficients: Coefficients) -> tuple[np.ndarray, np.ndarray]:
        """``(derivatives (F', p), column of each parameter (p,))`` of the fitted parameters.

        Every ``lin``, then the ``s`` of the columns whose time constant is fitted (``free_tau``).
        """
        derivatives = np.concatenate([coefficients.d_lin, coefficients.d_s[:, self.free_tau]], axis=1)
        return derivatives, self._owner

    def information(self, coefficients: Coefficients, *, keep: np.ndarray | None = None) -> np.ndarray:
        """Gauss-Newton matrix ``Re sum_w D^H M D`` of the packed parameters (or of those in ``keep``)."""
        derivatives, owner = self.jacobian(coefficients)
        M = self._m_owner
        if keep is not None:
            derivatives, owner = derivatives[:, keep], owner[keep]
            M = self.system.M[:, owner][:, :, owner]
        return np.einsum("fp,fpq,fq->pq", derivatives.conj(), M, derivatives).real

    def _step_terms(self, coefficients: Coefficients, product: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """:meth:`information` and the cost's gradient in the packed parameters, from one Jacobian.

        ``product`` is ``M theta`` (:meth:`.RowSystem.cost_and_product` computes it with the cost).
        """
        derivatives, owner = self.jacobian(coefficients)
        conjugate = derivatives.conj()
        H = np.einsum("fp,fpq,fq->pq", conjugate, self._m_owner, derivatives).real
        misfit = product - self.system.v
        return H, 2.0 * np.einsum("fp,fp->p", conjugate, misfit[:, owner]).real

    def fit(
        self, start: RowParameters, *, iterations: int = MAX_ITERATIONS, settled_above: float = np.inf
    ) -> tuple[RowParameters, float]:
        """Fit ``lin`` and ``s`` from ``start`` with its delays held: ``(parameters, cost)``.

        ``iterations`` caps the steps (a few from a good start already give
        the cost to far below one unit of chi-square); a cost still above
        ``settled_above`` after the first step ends the fit there (a delay
        neighbour whose outcome is settled: :data:`~.fit.SETTLED`).
        """
        lower, upper = self._bounds()
        x = np.minimum(np.maximum(self._pack(start), lower), upper)  # np.clip without its wrapper's cost
        coefficients = self.coefficients(self._unpack(x, start))
        cost, product = self.system.cost_and_product(coefficients.theta)
        damping = 1e-3
        for _ in range(iterations):
            H, g = self._step_terms(coefficients, product)
            diagonal = H.diagonal()
            diagonal = np.maximum(diagonal, 1e-12 * max(1.0, float(np.abs(diagonal).max())))
            scaling, rhs = np.diag(diagonal), -0.5 * g  # the same for every damping tried
            while damping < 1e12:
                step = np.linalg.solve(H + damping * scaling, rhs)
                trial = np.minimum(np.maximum(x + step, lower), upper)
                trial_coefficients = self.coefficients(self._unpack(trial, start))
                trial_cost, trial_product = self.system.cost_and_product(trial_coefficients.theta)
                if trial_cost <= cost:
                    break
                damping *= 10.0
            else:
                break
            decrease = cost - trial_cost
            x, coefficients, cost, product = trial, trial_coefficients, trial_cost, trial_product
            damping = max(damping / 10.0, 1e-9)
            if decrease <= COST_TOLERANCE or cost > settled_above:
                break
        return self._unpack(x, start), float(cost)
