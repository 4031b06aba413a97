"""The true plant: a transfer matrix (FOPTD, integrating, empty elements), measurement noise, optional load."""

from __future__ import annotations

import numpy as np

from .model import TransferMatrix


def noise_generator(seed: int) -> np.random.Generator:
    """The measurement-noise stream of run ``seed`` (shared by batch and ROS runs)."""
    return np.random.default_rng([int(seed), 0])


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
        Seed of the noise stream.
    """

    def __init__(self, model: TransferMatrix, noise_std, seed: int) -> None:
        self.model = model
        self._ss = ss = model.state_space()
        self._C = ss.C
        self._noise_std = np.broadcast_to(np.asarray(noise_std, dtype=float), (model.n_outputs,)).copy()
        self._rng = noise_generator(seed)
        self._x = np.zeros(ss.A.shape[0])

    def output(self) -> np.ndarray:
        """Noise-free output ``y(k)`` [output unit]."""
        return self._C @ self._x

    def measure(self) -> np.ndarray:
        """Measured output ``y(k)`` with noise; draws one noise sample per call."""
        return self.output() + self._noise_std * self._rng.standard_normal(self.model.n_outputs)

    def advance(self, u, *, disturbance=None) -> None:
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
        u = np.asarray(u, dtype=float)
        if disturbance is not None:
            u = u + np.asarray(disturbance, dtype=float)
        self._x = self._ss.advance(self._x, u)
