"""Matrices of first-order-plus-time-delay (FOPTD) transfer functions.

An element is ``G_ik(s) = K exp(-theta s) / (tau s + 1)``.  Sampled with a
zero-order hold at ``Ts`` and a delay of whole samples ``d = theta / Ts`` it is
exactly

    G_ik(z) = b z^-(1 + d) / (1 - a z^-1),   a = exp(-Ts / tau),  b = K (1 - a)

so ``y(k) = a y(k-1) + b u(k-1-d)``.  Frequencies are in rad/sample.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from .results import ElementModel

SCENARIOS = ("none", "gain", "time_constant", "delay", "full")
"""Mismatch scenarios of the paper's Table 2: which parts of a mismatch apply."""


def element_name(i: int, k: int, n: int) -> str:
    """Name of element (i, k), zero-based: ``G11`` style, ``G1_10`` when n > 9."""
    if n > 9:
        return f"G{i + 1}_{k + 1}"
    return f"G{i + 1}{k + 1}"


@dataclass(frozen=True)
class DiscreteFoptd:
    """ZOH discretization of a FOPTD matrix, element-wise.

    Attributes
    ----------
    pole : ndarray, shape (n_outputs, n_inputs)
        ``a = exp(-Ts / tau)``.
    numerator : ndarray, shape (n_outputs, n_inputs)
        ``b = K (1 - a)``.
    delay_samples : ndarray of int, shape (n_outputs, n_inputs)
        Dead time in whole samples (the ZOH adds one more sample of lag).
    """

    pole: np.ndarray
    numerator: np.ndarray
    delay_samples: np.ndarray

    def frequency_response(self, omega: np.ndarray) -> np.ndarray:
        """Complex response at ``omega`` [rad/sample], shape (n_out, n_in, len(omega))."""
        z_inv = np.exp(-1j * np.asarray(omega, dtype=float))
        a = self.pole[..., None]
        b = self.numerator[..., None]
        d = self.delay_samples[..., None]
        return b * z_inv ** (1 + d) / (1.0 - a * z_inv)

    def filter_coefficients(self, i: int, k: int) -> tuple[np.ndarray, np.ndarray]:
        """``(b, a)`` polynomials in z^-1 of element (i, k) for ``scipy.signal.lfilter``."""
        d = int(self.delay_samples[i, k])
        num = np.zeros(d + 2)
        num[-1] = self.numerator[i, k]
        return num, np.array([1.0, -self.pole[i, k]])


@dataclass(frozen=True)
class StateSpace:
    """Discrete realization ``x+ = A x + B u``, ``y = C x`` of a FOPTD matrix.

    Each input feeds a shift register as long as its largest delay; each
    element is one first-order state reading the register tap of its delay.
    """

    A: np.ndarray
    B: np.ndarray
    C: np.ndarray


@dataclass(frozen=True)
class Mismatch:
    """Plant-model mismatch per element: ``G = Ghat`` with these changes.

    Attributes
    ----------
    gain_pct : ndarray
        Relative gain change ``(K - Khat) / Khat`` in percent.
    time_constant_pct : ndarray
        Relative time-constant change in percent.
    delay_samples : ndarray of int
        Delay change ``D - Dhat`` in samples.
    """

    gain_pct: np.ndarray
    time_constant_pct: np.ndarray
    delay_samples: np.ndarray

    @classmethod
    def zero(cls, n_outputs: int, n_inputs: int) -> Mismatch:
        """No mismatch at all: the plant equals the model."""
        z = np.zeros((n_outputs, n_inputs))
        return cls(z, z.copy(), z.astype(int))

    def for_scenario(self, scenario: str) -> Mismatch:
        """Keep only the parts of the mismatch that ``scenario`` applies (Table 2)."""
        if scenario not in SCENARIOS:
            raise ValueError(f"unknown scenario {scenario!r}; choose one of {', '.join(SCENARIOS)}")
        zero = Mismatch.zero(*self.gain_pct.shape)
        return Mismatch(
            self.gain_pct if scenario in ("gain", "full") else zero.gain_pct,
            self.time_constant_pct if scenario in ("time_constant", "full") else zero.time_constant_pct,
            self.delay_samples if scenario in ("delay", "full") else zero.delay_samples,
        )

    @property
    def gain_ratio(self) -> np.ndarray:
        """Injected ``K / Khat``."""
        return 1.0 + self.gain_pct / 100.0


@dataclass(frozen=True)
class FoptdMatrix:
    """An n_outputs x n_inputs matrix of FOPTD elements with a sample time.

    Attributes
    ----------
    gain : ndarray, shape (n_outputs, n_inputs)
        Steady-state gains K [output unit / input unit].
    time_constant : ndarray
        Time constants tau [time unit of ``sample_time``], all > 0.
    delay : ndarray
        Dead times theta [time unit], whole multiples of ``sample_time``.
    sample_time : float
        Ts [time unit].
    output_names, input_names : tuple of str
        Channel names, used on topics and in reports.
    name : str
        Name of the system.
    """

    gain: np.ndarray
    time_constant: np.ndarray
    delay: np.ndarray
    sample_time: float
    output_names: tuple[str, ...] = field(default=())
    input_names: tuple[str, ...] = field(default=())
    name: str = ""

    def __post_init__(self) -> None:
        for attr in ("gain", "time_constant", "delay"):
            object.__setattr__(self, attr, np.array(getattr(self, attr), dtype=float, ndmin=2))
        shape = self.gain.shape
        if self.time_constant.shape != shape or self.delay.shape != shape:
            raise ValueError("gain, time_constant and delay must have the same shape")
        if not self.output_names:
            object.__setattr__(self, "output_names", tuple(f"y{i + 1}" for i in range(shape[0])))
        if not self.input_names:
            object.__setattr__(self, "input_names", tuple(f"u{k + 1}" for k in range(shape[1])))

    @property
    def n_outputs(self) -> int:
        """Controlled outputs (rows)."""
        return self.gain.shape[0]

    @property
    def n_inputs(self) -> int:
        """Manipulated inputs (columns)."""
        return self.gain.shape[1]

    @property
    def delay_samples(self) -> np.ndarray:
        """Dead times in whole samples (int)."""
        return np.rint(self.delay / self.sample_time).astype(int)

    def element_names(self) -> list[str]:
        """Row-major element names ``G11, G12, ...``."""
        n = max(self.n_outputs, self.n_inputs)
        return [element_name(i, k, n) for i in range(self.n_outputs) for k in range(self.n_inputs)]

    def element_models(self) -> dict[str, tuple[int, int, ElementModel]]:
        """Row-major element name to ``(row, column, ElementModel)``, as diagnoses report them."""
        names = self.element_names()
        delays = self.delay_samples
        out = {}
        for j, name in enumerate(names):
            i, k = divmod(j, self.n_inputs)
            out[name] = (
                i,
                k,
                ElementModel("foptd", float(self.gain[i, k]), float(self.time_constant[i, k]), int(delays[i, k])),
            )
        return out

    def settling_samples(self, time_constants: float = 8.0) -> int:
        """Samples until every element forgets its initial state to ``exp(-time_constants)``.

        ``time_constants`` x the largest tau plus the largest delay, in samples.
        """
        return (
            int(np.ceil(time_constants * self.time_constant.max() / self.sample_time))
            + int(self.delay_samples.max())
            + 1
        )

    def discretize(self) -> DiscreteFoptd:
        """Exact zero-order-hold discretization with the delay in whole samples."""
        pole = np.exp(-self.sample_time / self.time_constant)
        return DiscreteFoptd(pole, self.gain * (1.0 - pole), self.delay_samples)

    def with_mismatch(self, mismatch: Mismatch) -> FoptdMatrix:
        """The plant ``G`` that differs from this model by ``mismatch``."""
        return replace(
            self,
            gain=self.gain * (1.0 + mismatch.gain_pct / 100.0),
            time_constant=self.time_constant * (1.0 + mismatch.time_constant_pct / 100.0),
            delay=self.delay + mismatch.delay_samples * self.sample_time,
        )

    def with_time_constant(self, i: int, k: int, time_constant: float) -> FoptdMatrix:
        """A copy with element (i, k)'s time constant replaced [time unit]."""
        tau = self.time_constant.copy()
        tau[i, k] = time_constant
        return replace(self, time_constant=tau)

    def state_space(self) -> StateSpace:
        """Minimal-per-element realization with one shift register per input."""
        disc = self.discretize()
        n_out, n_in = self.n_outputs, self.n_inputs
        lengths = disc.delay_samples.max(axis=0)
        reg_start = n_out * n_in + np.concatenate(([0], np.cumsum(lengths)[:-1]))
        nx = n_out * n_in + int(lengths.sum())
        A = np.zeros((nx, nx))
        B = np.zeros((nx, n_in))
        C = np.zeros((n_out, nx))
        for k in range(n_in):
            start = reg_start[k]
            if lengths[k] > 0:
                B[start, k] = 1.0
                for t in range(1, lengths[k]):
                    A[start + t, start + t - 1] = 1.0
            for i in range(n_out):
                e = i * n_in + k
                A[e, e] = disc.pole[i, k]
                d = disc.delay_samples[i, k]
                if d == 0:
                    B[e, k] = disc.numerator[i, k]
                else:
                    A[e, start + d - 1] = disc.numerator[i, k]
                C[i, e] = 1.0
        return StateSpace(A, B, C)

    def element_outputs(self, u: np.ndarray) -> np.ndarray:
        """Per-element model outputs ``yhat_ik = G_ik u_k``.

        Parameters
        ----------
        u : ndarray, shape (N, n_inputs)
            Inputs.  The filters start at steady state for ``u[0]``; the true
            initial state is unknown, so drop the first
            :meth:`settling_samples` of the result before using it.

        Returns
        -------
        ndarray, shape (N, n_outputs, n_inputs)
        """
        from scipy.signal import lfilter, lfilter_zi

        u = np.asarray(u, dtype=float)
        disc = self.discretize()
        out = np.empty((u.shape[0], self.n_outputs, self.n_inputs))
        for i in range(self.n_outputs):
            for k in range(self.n_inputs):
                b, a = disc.filter_coefficients(i, k)
                zi = lfilter_zi(b, a) * u[0, k]
                out[:, i, k] = lfilter(b, a, u[:, k], zi=zi)[0]
        return out
