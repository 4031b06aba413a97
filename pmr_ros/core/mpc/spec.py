"""What defines a linear MPC and what it reports: its tuning, its matrices, its solve counters."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

__all__ = ["MpcMatrices", "MpcStatistics", "MpcTuning"]


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
    input_target : ndarray, shape (n_inputs,)
        Where inputs rest in the freedom the setpoints leave (ideal resting
        values) [input unit, deviation from nominal].
    input_target_weight : ndarray, shape (n_inputs,)
        S, per input, how strongly it is held at its target there
        [1/input unit^2]; no effect when the setpoints fix every input.
    ramp_filter_samples : float
        Time constant of the slope estimate of integrating outputs'
        disturbances [samples]; 0 is deadbeat.
    output_mode : tuple of str
        ``setpoint`` or ``zone`` per output; empty: every output a setpoint.
        A zone output has no tracking penalty (``Q_i = 0``).
    output_low, output_high : ndarray, shape (n_outputs,)
        Soft limits per output [output unit, deviation from nominal],
        ``-inf``/``inf`` where there is none; empty: none.
    zone_weight : ndarray, shape (n_outputs,)
        Penalty on the squared distance outside the limits, per checked point
        of the horizon [1/output unit^2].
    """

    prediction_horizon: int
    control_horizon: int
    output_weight: np.ndarray
    move_weight: np.ndarray
    u_min: np.ndarray
    u_max: np.ndarray
    du_max: np.ndarray
    input_target: np.ndarray
    input_target_weight: np.ndarray
    ramp_filter_samples: float
    output_mode: tuple[str, ...] = ()
    output_low: np.ndarray = field(default_factory=lambda: np.zeros(0))
    output_high: np.ndarray = field(default_factory=lambda: np.zeros(0))
    zone_weight: np.ndarray = field(default_factory=lambda: np.zeros(0))

    @property
    def zone_outputs(self) -> np.ndarray:
        """Which outputs are zone CVs (no tracking penalty), bool shape (n_outputs,) or (0,) when none is."""
        return np.array([mode == "zone" for mode in self.output_mode], dtype=bool)

    @property
    def limited_outputs(self) -> np.ndarray:
        """Which outputs have a finite soft limit, bool shape (n_outputs,) or (0,)."""
        low, high = np.asarray(self.output_low, dtype=float), np.asarray(self.output_high, dtype=float)
        if low.size == 0:
            return np.zeros(0, dtype=bool)
        return np.isfinite(low) | np.isfinite(high)

    @property
    def zones_active(self) -> bool:
        """Whether any output is a zone CV or has a limit (else the controller is the plain tracking one)."""
        return bool(np.any(self.zone_outputs) or np.any(self.limited_outputs))


@dataclass(frozen=True)
class MpcMatrices:
    """Read-only view of the matrices a :class:`LinearMpc` computes with.

    For code that evaluates the same controller for many runs at once (the
    lockstep batch simulator) or analyses the closed loop.  ``z`` stacks
    ``[x (nx); u_prev (n_in); r (n_out); d (n_out); p (n_ramps)]``.

    Attributes
    ----------
    A, B, C : ndarray
        The model's realization ``x+ = A x + B u``, ``yhat = C x``.
    gain : ndarray, shape (Nc*n_in, nz)
        Unconstrained optimum: ``dU* = gain @ z + gain_offset``.
    gain_offset : ndarray, shape (Nc*n_in,)
    gradient : ndarray, shape (Nc*n_in, nz)
        The QP's linear term: ``q = gradient @ z + gradient_offset``.
    gradient_offset : ndarray, shape (Nc*n_in,)
    """

    A: np.ndarray
    B: np.ndarray
    C: np.ndarray
    gain: np.ndarray
    gain_offset: np.ndarray
    gradient: np.ndarray
    gradient_offset: np.ndarray


@dataclass
class MpcStatistics:
    """Counters of the QP solves, for benchmarks and health reporting.

    ``solves``: steps whose unconstrained optimum broke a limit; ``fallbacks``: of those, solves the
    active-set method gave to OSQP; ``failures``: solves neither managed (the input was held).
    """

    steps: int = 0
    solves: int = 0
    failures: int = 0
    fallbacks: int = 0
    solve_time_s: list[float] | None = None
