"""The true plant: a transfer matrix (FOPTD, integrating, empty elements), measurement noise, optional load.

Besides white measurement noise the plant may carry an unmeasured coloured
output disturbance (:class:`OutputDisturbance`): white noise through
``1 / (1 - p z^-1)``, a slow drift of each output the controller does not see
coming -- the low-frequency content real plants have and a white-noise
simulation lacks.  Its samples come from :class:`DisturbanceStream`, used
sample by sample by :class:`FoptdPlant` (the batch ``simulate`` and the plant
node) and as a whole sequence by the lockstep batch, with the same arithmetic.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from .model import TransferMatrix

__all__ = ["DisturbanceStream", "FoptdPlant", "OutputDisturbance", "disturbance_generator", "noise_generator"]


def noise_generator(seed: int) -> np.random.Generator:
    """The measurement-noise stream of run ``seed`` (shared by batch and ROS runs)."""
    return np.random.default_rng([int(seed), 0])


def disturbance_generator(seed: int) -> np.random.Generator:
    """The output-disturbance stream of run ``seed``: independent of the measurement noise's."""
    return np.random.default_rng([int(seed), 1])


@dataclass(frozen=True)
class OutputDisturbance:
    """An unmeasured coloured output disturbance: ``d_i = e_i / (1 - pole z^-1)``, ``e_i`` white, stationary.

    Attributes
    ----------
    std : ndarray, shape (n_outputs,)
        Standard deviation of the disturbance ``d_i`` itself [output unit]; 0
        everywhere: no disturbance.  The white noise that drives it has
        ``std sqrt(1 - pole^2)``.
    pole : float
        ``p`` in [0, 1): 0 is white, 0.97 a drift with a time constant of
        about 33 samples.
    """

    std: np.ndarray
    pole: float

    @property
    def active(self) -> bool:
        """Whether any output is disturbed."""
        return bool(np.any(np.asarray(self.std) > 0))

    @classmethod
    def off(cls, n_outputs: int) -> OutputDisturbance:
        """No disturbance on ``n_outputs`` outputs."""
        return cls(np.zeros(n_outputs), 0.0)


class DisturbanceStream:
    """The samples ``d(0), d(1), ...`` of an :class:`OutputDisturbance` for run ``seed``.

    ``d(0) = std e(0)`` is drawn from the stationary distribution (no start-up
    transient), then ``d(k) = pole d(k-1) + std sqrt(1 - pole^2) e(k)``, ``e``
    standard normal: every sample has standard deviation ``std``.

    Parameters
    ----------
    settings : OutputDisturbance
    n_outputs : int
    seed : int
        Seed of :func:`disturbance_generator`.
    """

    def __init__(self, settings: OutputDisturbance, n_outputs: int, seed: int) -> None:
        self._std = np.broadcast_to(np.asarray(settings.std, dtype=float), (n_outputs,)).copy()
        self._pole = float(settings.pole)
        self._innovation = self._std * np.sqrt(1.0 - self._pole**2)
        self._rng = disturbance_generator(seed)
        self._n = n_outputs
        self._d: np.ndarray | None = None

    def _next(self, e: np.ndarray) -> np.ndarray:
        if self._d is None:
            self._d = self._std * e
        else:
            self._d = self._pole * self._d + self._innovation * e
        return self._d

    def draw(self) -> np.ndarray:
        """The next sample ``d(k)``, shape (n_outputs,) [output unit]."""
        return self._next(self._rng.standard_normal(self._n))

    def sequence(self, samples: int) -> np.ndarray:
        """The next ``samples`` samples, shape (samples, n_outputs): the same numbers as ``draw`` called that often."""
        # one draw of the whole block equals ``samples`` draws of n (numpy Generator)
        e = self._rng.standard_normal((samples, self._n))
        out = np.empty((samples, self._n))
        for k in range(samples):
            out[k] = self._next(e[k])
        return out


class FoptdPlant:
    """The true plant ``G``, stepped one sample at a time.

    The sample convention is that of a sampled-data loop: ``measure()`` returns
    ``y(k)``, which depends on inputs up to ``u(k-1)``; ``advance(u)`` applies
    ``u(k)`` over the next sample.

    Parameters
    ----------
    model : TransferMatrix
        The plant (deviation variables, starting at rest).
    noise_std : array_like, shape (n_outputs,)
        Standard deviation of the additive white Gaussian measurement noise
        [output unit].
    seed : int
        Seed of the noise stream (and of the disturbance's).
    disturbance : OutputDisturbance, optional
        An unmeasured coloured output disturbance added to every measurement;
        none by default (then the measurements are those of a plant without one,
        bit for bit).
    """

    def __init__(
        self, model: TransferMatrix, noise_std: ArrayLike, seed: int, *, disturbance: OutputDisturbance | None = None
    ) -> None:
        self.model = model
        self._ss = ss = model.state_space()
        self._C = ss.C
        self._noise_std = np.broadcast_to(np.asarray(noise_std, dtype=float), (model.n_outputs,)).copy()
        self._rng = noise_generator(seed)
        self._x = np.zeros(ss.A.shape[0])
        self._disturbance = None
        if disturbance is not None and disturbance.active:
            self._disturbance = DisturbanceStream(disturbance, model.n_outputs, seed)

    def output(self) -> np.ndarray:
        """Noise-free output ``y(k)`` [output unit]."""
        return self._C @ self._x

    def measure(self) -> np.ndarray:
        """Measured output ``y(k)`` with noise (and disturbance); draws one noise sample per call."""
        y = self.output() + self._noise_std * self._rng.standard_normal(self.model.n_outputs)
        if self._disturbance is not None:
            y = y + self._disturbance.draw()
        return y

    def advance(self, u: ArrayLike, *, disturbance: ArrayLike | None = None) -> None:
        """Hold ``u(k)`` [input unit] for one sample.

        Parameters
        ----------
        u : array_like, shape (n_inputs,)
            The input applied [input unit].
        disturbance : array_like, shape (n_inputs,), optional
            An unmeasured input disturbance (a load) added to ``u`` inside the
            plant: it acts like a move of the inputs that nobody sees
            [input unit].
        """
        applied = np.asarray(u, dtype=float)
        if disturbance is not None:
            applied = applied + np.asarray(disturbance, dtype=float)
        self._x = self._ss.advance(self._x, applied)
