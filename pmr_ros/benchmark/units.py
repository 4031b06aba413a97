"""The benchmark's four units: which params file each is, and its configuration with a run's mismatch applied."""

from __future__ import annotations

from dataclasses import replace
from functools import cache

import numpy as np

from ..config import PmrConfig, load_config
from ..core.sim.model import Mismatch
from ..core.sim.true_plant import OutputDisturbance
from ..resources import share_dir

__all__ = ["DISTURBANCE_FACTOR", "DISTURBANCE_POLE", "UNITS", "run_config", "unit_config"]

UNITS = {
    "wood_berry": "wood_berry.yaml",
    "three_by_three": "three_by_three.yaml",
    "debutanizer": "industrial_column.yaml",
    "sparse_sixteen": "sparse_sixteen.yaml",
}
"""Unit name -> its params file in ``config/``, smallest first."""

DISTURBANCE_FACTOR = 3.0
"""The coloured output disturbance's standard deviation, in units of each output's measurement noise."""

DISTURBANCE_POLE = 0.97
"""Its pole: white noise through ``1 / (1 - 0.97 z^-1)``, a drift over about 33 samples."""


@cache
def unit_config(unit: str) -> PmrConfig:
    """The unit's shipped configuration (its own model, noise, PRBS, dither and MPC tuning).

    Raises
    ------
    ValueError
        ``unit`` is none of :data:`UNITS`.
    """
    if unit not in UNITS:
        raise ValueError(f"unknown unit {unit!r}; choose one of {', '.join(UNITS)}")
    return load_config(share_dir("config", UNITS[unit]) / UNITS[unit])


def run_config(
    unit: str, *, gain_pct: np.ndarray, tau_pct: np.ndarray, delay_samples: np.ndarray, disturbance: bool
) -> PmrConfig:
    """The unit's configuration with one run's mismatch (full arrays, n_outputs x n_inputs) and disturbance.

    The plant of scenario ``full`` then is the model under this mismatch.
    """
    base = unit_config(unit)
    mismatch = Mismatch(
        np.asarray(gain_pct, dtype=float), np.asarray(tau_pct, dtype=float), np.asarray(delay_samples, dtype=int)
    )
    n_out = base.model.n_outputs
    if disturbance:
        std = DISTURBANCE_FACTOR * np.broadcast_to(np.asarray(base.noise_std, dtype=float), (n_out,))
        coloured = OutputDisturbance(std=std.copy(), pole=DISTURBANCE_POLE)
    else:
        coloured = OutputDisturbance.off(n_out)
    return replace(base, mismatch=mismatch, disturbance=coloured)
