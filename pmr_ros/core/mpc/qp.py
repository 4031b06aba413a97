"""A dense convex QP solver for the MPC: the dual active-set method of Goldfarb & Idnani (1983).

    min  x' H x / 2 + q' x   s.t.  lower <= A x <= upper,   H positive definite

``H`` and ``A`` are fixed (factored once); each solve gets ``q`` and the
bounds.  The method starts from the unconstrained minimum ``-H^-1 q`` and adds
the most violated constraint, one at a time, keeping the dual feasible, so it
ends at the exact optimum (to rounding) after about as many iterations as
there are active constraints -- few in an MPC step, however many variables.
Given a guess of the active set (the previous MPC step's), it starts instead
from the minimizer on the guessed constraints, those with negative multipliers
dropped -- dual feasible, so the method applies unchanged and ends at the same
unique minimizer in the few iterations the active set changed by.
The MPC's QP always has the feasible point ``dU = 0`` (the previous input is
within its limits), so a failure can only be numerical; :meth:`solve` then
says so and the caller falls back.

The active set is kept in the factorisation ``J' N = [R; 0]`` (``N`` the
normals of the active constraints, ``J = L^-T Q`` with ``H = L L'``): a
constraint is added with one Householder reflection of the free columns of
``J``, dropped with Givens rotations that restore ``R``'s triangle.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import scipy.linalg

__all__ = ["DenseQp", "QpSolution"]


@dataclass(frozen=True)
class QpSolution:
    """What :meth:`DenseQp.solve` found.

    Attributes
    ----------
    x : ndarray
        The minimizer (the unconstrained one when nothing binds).
    active : tuple of int
        Active inequalities: ``+(i+1)`` for row i at its lower bound, ``-(i+1)`` at its upper.
    iterations : int
        Constraints added or dropped.
    solved : bool
        False when the iteration limit was reached or a step broke down (``x`` is then not to be used).
    """

    x: np.ndarray
    active: tuple[int, ...]
    iterations: int
    solved: bool


_qr_delete = getattr(scipy.linalg.qr_delete, "__wrapped__", scipy.linalg.qr_delete)
"""``scipy.linalg.qr_delete`` itself, without the wrapper that scipy >= 1.15 puts around it for stacks of
matrices (two thirds of a drop's time on the MPC's small matrices; one matrix here, so the same result)."""


def _upper_inverse(triangle: np.ndarray) -> np.ndarray:
    """The inverse of an upper triangular matrix (LAPACK ``trtri``: a twentieth of ``solve_triangular``'s overhead)."""
    inverse, info = scipy.linalg.lapack.dtrtri(triangle, lower=0)
    if info != 0:
        raise np.linalg.LinAlgError(f"singular active-set factor (trtri info {info})")
    return np.asarray(inverse)


def _signed_rows(signed: Sequence[int] | np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Rows and which are at their lower bound, of signed rows (``+(row+1)`` lower, ``-(row+1)`` upper)."""
    signed = np.asarray(signed, dtype=int)
    return np.abs(signed) - 1, signed > 0


class _ActiveSet:
    """The active constraints, their multipliers and the factorisation ``J' N = [R; 0]`` (with ``R^-1``)."""

    def __init__(self, j0: np.ndarray) -> None:
        n = j0.shape[0]
        self.J = j0.copy()
        self.R = np.zeros((n, n))
        self.R_inverse = np.zeros((n, n))
        self.signed: list[int] = []  # +(row+1) lower bound, -(row+1) upper bound
        self._u = np.zeros(n)

    @classmethod
    def with_constraints(cls, j0: np.ndarray, signed: list[int], normals: np.ndarray) -> _ActiveSet | None:
        """The factorisation with active set ``signed`` (``normals`` its columns); None if they are dependent."""
        active = cls(j0)
        k = len(signed)
        if not 0 < k <= j0.shape[0]:
            return None  # more constraints than variables are dependent
        orthogonal, triangle = np.linalg.qr(j0.T @ normals, mode="complete")
        diagonal = np.abs(np.diag(triangle))
        if not diagonal.min() > 1e-10 * diagonal.max():
            return None
        active.J = j0 @ orthogonal
        active.R[:k, :k] = triangle[:k]
        active.R_inverse[:k, :k] = _upper_inverse(triangle[:k])
        active.signed = list(signed)
        return active

    @property
    def size(self) -> int:
        return len(self.signed)

    @property
    def u(self) -> np.ndarray:
        """Multipliers of the active constraints (a view)."""
        return self._u[: self.size]

    def add(self, signed_row: int, d: np.ndarray, multiplier: float) -> None:
        """Append a constraint whose ``J' n`` is ``d``: a Householder reflection zeroes ``d[q+1:]``."""
        q = self.size
        d2 = d[q:]
        norm = math.sqrt(float(d2 @ d2))
        v = d2.copy()
        v[0] += math.copysign(norm, d2[0])
        vv = float(v @ v)
        if vv > 0.0:
            free = self.J[:, q:]
            free -= (free @ v)[:, None] * (v * (2.0 / vv))  # np.outer's product, without its overhead
        delta = -math.copysign(norm, d2[0])
        self.R[:q, q] = d[:q]
        self.R[q, q] = delta
        # [[R, r], [0, delta]]^-1 = [[R^-1, -R^-1 r / delta], [0, 1 / delta]]
        self.R_inverse[:q, q] = -(self.R_inverse[:q, :q] @ d[:q]) / delta
        self.R_inverse[q, q] = 1.0 / delta
        self._u[q] = multiplier
        self.signed.append(signed_row)

    def drop(self, index: int) -> None:
        """Remove active constraint ``index``; Givens rotations (``scipy.linalg.qr_delete``) restore R's triangle.

        The rotations ``G`` act on ``R`` from the left and on ``J`` from the right, so ``J' N = [R; 0]`` holds on.
        """
        q = self.size
        self.J, triangle = _qr_delete(self.J, self.R[:, :q], index, which="col", overwrite_qr=True, check_finite=False)
        self.R[:, : q - 1] = triangle
        self.R[:, q - 1] = 0.0
        self._u[index : q - 1] = self._u[index + 1 : q].copy()
        del self.signed[index]
        self.R_inverse[:] = 0.0
        if q > 1:
            self.R_inverse[: q - 1, : q - 1] = _upper_inverse(triangle[: q - 1])

    def copy(self) -> _ActiveSet:
        """An independent copy (the factorisation depends on the active normals only, not on q or the bounds)."""
        twin = _ActiveSet.__new__(_ActiveSet)
        twin.J, twin.R, twin.R_inverse, twin._u = self.J.copy(), self.R.copy(), self.R_inverse.copy(), self._u.copy()
        twin.signed = list(self.signed)
        return twin


class DenseQp:
    """The QP ``min x'Hx/2 + q'x, lower <= A x <= upper`` with fixed ``H`` and ``A``.

    Parameters
    ----------
    H : ndarray, shape (n, n)
        Symmetric positive definite Hessian.
    A : ndarray, shape (m, n)
        Constraint matrix.
    max_iterations : int, optional
        Adds and drops before giving up (default ``5 (n + m)``).
    """

    def __init__(self, H: np.ndarray, A: np.ndarray, *, max_iterations: int | None = None) -> None:
        lower_factor = scipy.linalg.cholesky(H, lower=True)
        self._j0 = scipy.linalg.solve_triangular(lower_factor, np.eye(H.shape[0]), lower=True).T  # L^-T
        self._minus_h_inverse = -(self._j0 @ self._j0.T)  # negated once, not at each solve (the same numbers)
        self._A = np.asarray(A, dtype=float)
        self._max_iterations = max_iterations or 5 * (H.shape[0] + self._A.shape[0])
        self._tolerance = 1e-12
        self._last: _ActiveSet | None = None  # the last solve's active set, for a warm start

    def solve(self, q: np.ndarray, *, lower: np.ndarray, upper: np.ndarray, guess: tuple[int, ...] = ()) -> QpSolution:
        """The minimizer for linear term ``q`` and bounds ``lower``, ``upper`` (``-inf``/``inf`` where none).

        ``guess``: an active set to start from (signed rows as in :attr:`QpSolution.active`, e.g. the
        previous MPC step's).  The method starts at the minimizer with the guessed constraints as
        equalities, those with a negative multiplier dropped (a dual-feasible start, as the method
        needs), so it ends at the same unique minimizer in fewer iterations; should that start break
        down, the method starts again from scratch.
        """
        x = self._minus_h_inverse @ q
        finite_lower, finite_upper = np.where(np.isfinite(lower), lower, 0.0), np.where(np.isfinite(upper), upper, 0.0)
        inverse_scale = 1.0 / (1.0 + np.maximum(np.abs(finite_lower), np.abs(finite_upper)))
        start = self._warm_start(x, guess, bounds=(lower, upper)) if guess else None
        x, active = start if start is not None else (x, _ActiveSet(self._j0))
        iterations = 0
        while True:
            signed = self._most_violated(x, lower, upper, inverse_scale, active.signed)
            if signed == 0:
                self._last = active
                return QpSolution(x, tuple(active.signed), iterations, True)
            x, iterations, ok = self._add(x, signed, bounds=(lower, upper), active=active, iterations=iterations)
            if not ok:
                if start is not None:  # the warm start's path broke down: the cold one may not
                    return self.solve(q, lower=lower, upper=upper)
                return QpSolution(x, tuple(active.signed), iterations, False)

    def _warm_start(
        self, x0: np.ndarray, guess: tuple[int, ...], *, bounds: tuple[np.ndarray, np.ndarray]
    ) -> tuple[np.ndarray, _ActiveSet] | None:
        """The minimizer with the ``guess`` constraints as equalities and its active set, multipliers >= 0.

        ``x = x0 + H^-1 N mu`` with ``N' x = b`` (``N`` the signed normals as columns, ``b`` their bounds);
        ``H^-1 N = J[:, :k] R`` and ``N' H^-1 N = R' R``.  The constraint with the most negative multiplier
        is dropped until none is left; None when nothing remains or the normals are dependent.  The
        factorisation of the last solve's active set is kept, so a guess equal to it needs no new one.
        """
        lower, upper = bounds
        last = self._last
        active = last.copy() if last is not None and tuple(last.signed) == guess else self._factorised(list(guess))
        while active is not None and active.size:
            k = active.size
            rows, at_lower = _signed_rows(active.signed)
            bound = np.where(at_lower, lower[rows], -upper[rows])
            if not np.all(np.isfinite(bound)):
                return None  # a guessed bound that is gone
            r_inverse = active.R_inverse[:k, :k]
            slack = bound - np.where(at_lower, 1.0, -1.0) * (self._A[rows] @ x0)
            multipliers = r_inverse @ (r_inverse.T @ slack)
            worst = int(np.argmin(multipliers))
            if not multipliers.max() >= 0.0:
                return None  # nothing of the guess stays: the cold start is as near
            if multipliers[worst] >= 0.0:
                active.u[:] = multipliers
                return x0 + active.J[:, :k] @ (active.R[:k, :k] @ multipliers), active
            active.drop(worst)
        return None

    def _factorised(self, signed: list[int]) -> _ActiveSet | None:
        """The factorisation of active set ``signed``, None when its normals are dependent."""
        rows, at_lower = _signed_rows(signed)
        normals = (self._A[rows] * np.where(at_lower, 1.0, -1.0)[:, None]).T
        return _ActiveSet.with_constraints(self._j0, signed, normals)

    def _most_violated(
        self, x: np.ndarray, lower: np.ndarray, upper: np.ndarray, inverse_scale: np.ndarray, skip: list[int]
    ) -> int:
        """The signed row of the most violated inequality (relative to its bound's size), 0 if none."""
        ax = self._A @ x
        below = (lower - ax) * inverse_scale
        above = (ax - upper) * inverse_scale
        for signed in skip:  # a few active rows: plain indexing beats building index arrays
            if signed > 0:
                below[signed - 1] = -np.inf
            else:
                above[-signed - 1] = -np.inf
        i_low, i_up = int(below.argmax()), int(above.argmax())
        worst = max(below[i_low], above[i_up])
        if not worst > self._tolerance:
            return 0
        return i_low + 1 if below[i_low] >= above[i_up] else -(i_up + 1)

    def _add(
        self,
        x: np.ndarray,
        signed: int,
        *,
        bounds: tuple[np.ndarray, np.ndarray],
        active: _ActiveSet,
        iterations: int,
    ) -> tuple[np.ndarray, int, bool]:
        """Steps towards making ``signed`` active (dropping constraints on the way); the new x."""
        lower, upper = bounds
        row = abs(signed) - 1
        normal = self._A[row] if signed > 0 else -self._A[row]
        bound = lower[row] if signed > 0 else -upper[row]
        multiplier = 0.0
        flat = 1e-14 * float(normal @ normal)  # curvature below this: a step along the constraint changes nothing
        while iterations < self._max_iterations:
            iterations += 1
            q = active.size
            d = active.J.T @ normal
            z = active.J[:, q:] @ d[q:]
            r = active.R_inverse[:q, :q] @ d[:q]
            partial, leaving = np.inf, -1
            blocking = (r > 0).nonzero()[0]
            if blocking.size:
                ratios = active.u[blocking] / r[blocking]
                best = int(np.argmin(ratios))
                partial, leaving = float(ratios[best]), int(blocking[best])
            curvature = float(z @ normal)
            full = -(normal @ x - bound) / curvature if curvature > flat else np.inf
            step = min(partial, full)
            if not math.isfinite(step):
                return x, iterations, False  # primal infeasible: cannot happen with dU = 0 feasible
            if math.isfinite(full):
                x = x + step * z
            active.u[:] -= step * r
            multiplier += step
            if step == full:
                active.add(signed, d, multiplier)
                return x, iterations, True
            active.drop(leaving)
        return x, iterations, False
