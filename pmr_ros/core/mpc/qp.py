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

Each row ``a`` of ``A`` is two one-sided constraints, ``a x >= lower`` and
``-a x >= -upper``; the solver works on the stacked rows ``C x >= b`` with
``C = [A; -A]`` and ``b = [lower; -upper]``, so that a constraint is one index
into ``C`` and ``b`` and the most violated one is one product and one argmax.
The active set is kept in the factorisation ``J' N = [R; 0]`` (``N`` the
normals of the active constraints, ``J = L^-T Q`` with ``H = L L'``): a
constraint is added with one Householder reflection of the free columns of
``J``, dropped with Givens rotations that restore ``R``'s triangle.  ``J'`` is
stored rather than ``J``, so that both act on contiguous rows.  The MPC's
matrices are small (tens of variables), so a solve's time is mostly the fixed
cost of each numpy call: the code keeps their number down.
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

_dger, _drot = scipy.linalg.blas.dger, scipy.linalg.blas.drot
"""BLAS's rank-one update and plane rotation, in place on contiguous rows: a fraction of numpy's several calls."""

_FEW_ROTATIONS = 3
"""Most rotations a drop applies itself, each two ``drot`` calls; more go to ``qr_delete`` in one call, whose
fixed cost is that of about three rotations.  An MPC step mostly drops one of the last few constraints."""


def _upper_inverse(triangle: np.ndarray) -> np.ndarray:
    """The inverse of an upper triangular matrix (LAPACK ``trtri``: a twentieth of ``solve_triangular``'s overhead)."""
    inverse, info = scipy.linalg.lapack.dtrtri(triangle, lower=0)
    if info != 0:
        raise np.linalg.LinAlgError(f"singular active-set factor (trtri info {info})")
    return np.asarray(inverse)


class _ActiveSet:
    """The active constraints, their multipliers and the factorisation ``J' N = [R; 0]`` (with ``R^-1``).

    Constraints are indices into the stacked rows ``C`` of :class:`DenseQp`; ``Jt`` is ``J'``.
    """

    def __init__(self, jt0: np.ndarray) -> None:
        n = jt0.shape[0]
        self.Jt = jt0.copy()  # C-ordered (ndarray.copy's default), as add and drop update its rows in place
        self.R = np.zeros((n, n))
        self.R_inverse = np.zeros((n, n))
        self.rows: list[int] = []
        self._u = np.zeros(n)

    @classmethod
    def with_constraints(cls, jt0: np.ndarray, rows: list[int], normals: np.ndarray) -> _ActiveSet | None:
        """The factorisation with active set ``rows`` (``normals`` their rows of C); None if they are dependent."""
        active = cls(jt0)
        k = len(rows)
        if not 0 < k <= jt0.shape[0]:
            return None  # more constraints than variables are dependent
        orthogonal, triangle = np.linalg.qr(jt0 @ normals.T, mode="complete")
        diagonal = np.abs(np.diag(triangle))
        if not diagonal.min() > 1e-10 * diagonal.max():
            return None
        active.Jt = orthogonal.T @ jt0  # J = J0 Q: J' N = Q' J0' N = [R; 0]
        active.R[:k, :k] = triangle[:k]
        active.R_inverse[:k, :k] = _upper_inverse(triangle[:k])
        active.rows = list(rows)
        return active

    @property
    def size(self) -> int:
        return len(self.rows)

    @property
    def u(self) -> np.ndarray:
        """Multipliers of the active constraints (a view)."""
        return self._u[: self.size]

    def add(self, row: int, d: np.ndarray, r: np.ndarray, multiplier: float) -> None:
        """Append a constraint whose ``J' n`` is ``d``: a Householder reflection zeroes ``d[q+1:]``.

        ``r`` is ``R^-1 d[:q]``, which the step towards the constraint computed already.
        """
        q = self.size
        d2 = d[q:]
        norm = math.sqrt(float(d2 @ d2))
        v = d2.copy()
        v[0] += math.copysign(norm, d2[0])
        vv = 2.0 * norm * (norm + abs(float(d2[0])))  # v @ v, without computing it
        if vv > 0.0:
            free = self.Jt[q:]  # rows of a C-ordered array: its transpose is Fortran-ordered, updated in place
            _dger(-2.0 / vv, v @ free, v, a=free.T, overwrite_a=1)  # free -= v (v' free) 2 / v'v, one BLAS call
        delta = -math.copysign(norm, d2[0])
        self.R[:q, q] = d[:q]
        self.R[q, q] = delta
        # [[R, r], [0, delta]]^-1 = [[R^-1, -R^-1 r / delta], [0, 1 / delta]]
        self.R_inverse[:q, q] = r / -delta
        self.R_inverse[q, q] = 1.0 / delta
        self._u[q] = multiplier
        self.rows.append(row)

    def drop(self, index: int) -> None:
        """Remove active constraint ``index``; Givens rotations restore R's triangle.

        Without column ``index``, R is upper Hessenberg from that column on; a rotation ``G`` of rows
        ``i, i+1`` zeroes each subdiagonal entry.  It acts on ``R`` and on ``J'`` from the left, so
        ``J' N = [R; 0]`` holds on.
        """
        q = self.size
        if q - 1 - index > _FEW_ROTATIONS:
            J, triangle = _qr_delete(
                self.Jt.T, self.R[:, :q], index, which="col", overwrite_qr=True, check_finite=False
            )
            self.Jt = np.ascontiguousarray(J.T)  # C-ordered, as add and _rotate_out update its rows in place
            self.R[:, : q - 1] = triangle
            self.R[:, q - 1] = 0.0
        else:
            self._rotate_out(index)
        self._u[index : q - 1] = self._u[index + 1 : q].copy()
        del self.rows[index]
        if index == q - 1:  # the leading block of a triangle's inverse is the inverse of its leading block
            self.R_inverse[:, q - 1] = 0.0
            self.R_inverse[q - 1] = 0.0
        else:
            self.R_inverse[:] = 0.0
            self.R_inverse[: q - 1, : q - 1] = _upper_inverse(self.R[: q - 1, : q - 1])

    def _rotate_out(self, index: int) -> None:
        """Column ``index`` out of R; the rotations that restore its triangle, on rows of R and J' in place."""
        q = self.size
        R, Jt = self.R, self.Jt
        R[:, index : q - 1] = R[:, index + 1 : q]
        R[:, q - 1] = 0.0
        for i in range(index, q - 1):
            a, b = float(R[i, i]), float(R[i + 1, i])
            if b != 0.0:
                h = math.hypot(a, b)
                _drot(R[i, i : q - 1], R[i + 1, i : q - 1], a / h, b / h, overwrite_x=1, overwrite_y=1)
                _drot(Jt[i], Jt[i + 1], a / h, b / h, overwrite_x=1, overwrite_y=1)
                R[i + 1, i] = 0.0  # exactly, not to rounding: R_inverse is the inverse of a triangle


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
        self._jt0 = scipy.linalg.solve_triangular(lower_factor, np.eye(H.shape[0]), lower=True)  # L^-1 = J0'
        self._minus_h_inverse = -(self._jt0.T @ self._jt0)  # negated once, not at each solve (the same numbers)
        A = np.asarray(A, dtype=float)
        self._m = A.shape[0]
        self._C = np.vstack([A, -A])  # rows k < m: a x >= lower; rows m + i: -a x >= -upper
        self._max_iterations = max_iterations or 5 * (H.shape[0] + self._m)
        self._tolerance = 1e-12
        self._last: tuple[tuple[int, ...], _ActiveSet | None] = ((), None)  # the last active set, signed and factorised

    def solve(self, q: np.ndarray, *, lower: np.ndarray, upper: np.ndarray, guess: tuple[int, ...] = ()) -> QpSolution:
        """The minimizer for linear term ``q`` and bounds ``lower``, ``upper`` (``-inf``/``inf`` where none).

        ``guess``: an active set to start from (signed rows as in :attr:`QpSolution.active`, e.g. the
        previous MPC step's).  The method starts at the minimizer with the guessed constraints as
        equalities, those with a negative multiplier dropped (a dual-feasible start, as the method
        needs), so it ends at the same unique minimizer in fewer iterations; should that start break
        down, the method starts again from scratch.
        """
        b = np.concatenate((lower, -upper))
        scale = self._inverse_scale(b)
        x = self._minus_h_inverse @ q
        start = self._warm_start(x, guess, b) if guess else None
        x, active = start if start is not None else (x, _ActiveSet(self._jt0))
        iterations = 0
        while True:
            row = self._most_violated(x, b, scale, active.rows)
            if row < 0:
                signed = self._signed(active.rows)
                self._last = signed, active
                return QpSolution(x, signed, iterations, True)
            x, iterations, ok = self._add(x, row, float(b[row]), active=active, iterations=iterations)
            if not ok:
                if start is not None:  # the warm start's path broke down: the cold one may not
                    return self.solve(q, lower=lower, upper=upper)
                return QpSolution(x, self._signed(active.rows), iterations, False)

    def _signed(self, rows: list[int]) -> tuple[int, ...]:
        """Rows of ``C`` as signed rows of ``A``: ``+(i+1)`` at the lower bound, ``-(i+1)`` at the upper."""
        m = self._m
        return tuple(row + 1 if row < m else m - row - 1 for row in rows)

    def _rows(self, signed: Sequence[int]) -> list[int]:
        """Signed rows of ``A`` as rows of ``C`` (the inverse of :meth:`_signed`)."""
        m = self._m
        return [s - 1 if s > 0 else m - s - 1 for s in signed]

    def _inverse_scale(self, b: np.ndarray) -> np.ndarray:
        """``1 / (1 + the size of row i's bounds)``, for both rows of C made of row i of A; absent bounds count 0."""
        magnitude = np.abs(b)
        magnitude[~np.isfinite(magnitude)] = 0.0
        half = 1.0 / (1.0 + np.maximum(magnitude[: self._m], magnitude[self._m :]))
        return np.concatenate((half, half))

    def _warm_start(
        self, x0: np.ndarray, guess: tuple[int, ...], b: np.ndarray
    ) -> tuple[np.ndarray, _ActiveSet] | None:
        """The minimizer with the ``guess`` constraints as equalities and its active set, multipliers >= 0.

        ``x = x0 + H^-1 N mu`` with ``N' x = b_N`` (``N`` the guessed rows of C as columns, ``b_N`` their
        bounds); ``H^-1 N = J[:, :k] R`` and ``N' H^-1 N = R' R``.  The constraint with the most negative
        multiplier is dropped until none is left; None when nothing remains or the normals are dependent.
        The factorisation of the last solve's active set is kept, so a guess equal to it needs no new one.
        """
        rows = self._rows(guess)
        slack = b - self._C @ x0  # of every row; N' x = b_N is R' R mu = slack[N]
        if not np.isfinite(slack[rows]).all():
            return None  # a guessed bound that is gone
        last_guess, last = self._last
        self._last = (), None  # taken over (changed below), or of no use
        active = last if last is not None and last_guess == guess else self._factorised(rows)
        while active is not None and active.size:
            k = active.size
            r_inverse = active.R_inverse[:k, :k]
            multipliers = r_inverse @ (r_inverse.T @ slack[active.rows])
            if not multipliers.max() >= 0.0:
                return None  # nothing of the guess stays: the cold start is as near
            worst = int(multipliers.argmin())
            if multipliers[worst] >= 0.0:
                active.u[:] = multipliers
                return x0 + (active.R[:k, :k] @ multipliers) @ active.Jt[:k], active
            active.drop(worst)
        return None

    def _factorised(self, rows: list[int]) -> _ActiveSet | None:
        """The factorisation of active set ``rows``, None when their normals are dependent."""
        return _ActiveSet.with_constraints(self._jt0, rows, self._C[rows])

    def _most_violated(self, x: np.ndarray, b: np.ndarray, scale: np.ndarray, skip: list[int]) -> int:
        """The row of C of the most violated inequality (relative to its bounds' size), -1 if none."""
        violation = (b - self._C @ x) * scale
        if skip:
            violation[skip] = -np.inf
        row = int(violation.argmax())
        return row if violation[row] > self._tolerance else -1

    def _add(
        self, x: np.ndarray, row: int, bound: float, *, active: _ActiveSet, iterations: int
    ) -> tuple[np.ndarray, int, bool]:
        """Steps towards making ``row`` active (dropping constraints on the way); the new x."""
        normal = self._C[row]
        multiplier = 0.0
        flat = 1e-14 * float(normal @ normal)  # curvature below this: a step along the constraint changes nothing
        while iterations < self._max_iterations:
            iterations += 1
            q = active.size
            d = active.Jt @ normal
            z = d[q:] @ active.Jt[q:]  # the step in x: J's free columns times d's free part
            partial, leaving, r = math.inf, -1, d[:0]
            if q:  # the active multipliers change by -step * r; the first to reach zero blocks the step
                r = active.R_inverse[:q, :q] @ d[:q]
                # a few numbers: a Python loop is cheaper than the five numpy calls of a masked argmin
                for i, (u_i, r_i) in enumerate(zip(active.u.tolist(), r.tolist(), strict=True)):
                    if r_i > 0.0 and u_i / r_i < partial:
                        partial, leaving = u_i / r_i, i
            curvature = float(z @ normal)
            full = (bound - float(normal @ x)) / curvature if curvature > flat else math.inf
            step = min(partial, full)
            if not math.isfinite(step):
                return x, iterations, False  # primal infeasible: cannot happen with dU = 0 feasible
            if math.isfinite(full):
                x = x + step * z
            if q:
                active.u[:] -= step * r
            multiplier += step
            if step == full:
                active.add(row, d, r, multiplier)
                return x, iterations, True
            active.drop(leaving)
        return x, iterations, False
