"""Plant-model mismatch per element: the changes that make the plant ``G`` from the model ``Ghat``."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["SCENARIOS", "Mismatch"]

SCENARIOS = ("none", "gain", "time_constant", "delay", "full")
"""The paper's mismatch scenarios (Table 2): which parts of a mismatch apply."""


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
