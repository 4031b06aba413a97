"""The benchmark's units (and their routine-operation variants): each one's configuration, and a run's."""

from __future__ import annotations

from dataclasses import replace
from functools import cache

import numpy as np

from ..config import PmrConfig, load_config
from ..core.sim.model import Mismatch
from ..core.sim.true_plant import OutputDisturbance
from ..resources import share_dir

__all__ = [
    "DISTURBANCE_FACTOR",
    "DISTURBANCE_POLE",
    "ROUTINE_STEP_INTERVAL",
    "ROUTINE_UNITS",
    "UNITS",
    "all_units",
    "run_config",
    "unit_config",
]

UNITS = {
    "wood_berry": "wood_berry.yaml",
    "three_by_three": "three_by_three.yaml",
    "debutanizer": "industrial_column.yaml",
    "sparse_sixteen": "sparse_sixteen.yaml",
}
"""Unit name -> its params file in ``config/``, smallest first; their setpoints move as the file's PRBS."""

ROUTINE_UNITS: dict[str, tuple[str, float | str]] = {
    "wood_berry_routine": ("wood_berry", 0.02),
    "debutanizer_routine": ("debutanizer", "debutanizer_routine.yaml"),
}
"""Routine operation of a unit: name -> (the unit of :data:`UNITS`, its MV dither).

The unit's model, noise and MPC tuning, but rare operator setpoint steps instead of the PRBS
(``prbs.mode: steps``: every CV's setpoint jumps to nominal +/- U(0, 1) x the unit's PRBS amplitude
after exponential intervals of :data:`ROUTINE_STEP_INTERVAL` samples on average) and a small MV
dither: an amplitude on every MV [MV unit] (Wood-Berry, which ships none: the value of
``benchmarks/bench_routine.py``), or the params file whose ``excitation`` is taken (the debutanizer:
``config/debutanizer_routine.yaml``'s, half its step-test file's; that file's zones, DVs and manual
stretches are not used here).
"""

ROUTINE_STEP_INTERVAL = 240.0
"""Mean time between two setpoint changes of a CV in routine operation [samples]: 4 h at Ts = 1 min."""

DISTURBANCE_FACTOR = 3.0
"""The coloured output disturbance's standard deviation, in units of each output's measurement noise."""

DISTURBANCE_POLE = 0.97
"""Its pole: white noise through ``1 / (1 - 0.97 z^-1)``, a drift over about 33 samples."""


def all_units() -> tuple[str, ...]:
    """Every unit name of the scenarios: :data:`UNITS`, then :data:`ROUTINE_UNITS`."""
    return (*UNITS, *ROUTINE_UNITS)


def _routine(unit: str) -> PmrConfig:
    """The routine-operation variant ``unit`` of :data:`ROUTINE_UNITS`."""
    base_unit, dither = ROUTINE_UNITS[unit]
    base = unit_config(base_unit)
    if isinstance(dither, str):
        excitation = load_config(share_dir("config", dither) / dither).excitation
    else:
        excitation = replace(base.excitation, mv_dither_amplitude=np.full(base.model.n_inputs, float(dither)))
    prbs = replace(base.prbs, mode="steps", step_interval_samples=ROUTINE_STEP_INTERVAL, step_amplitude=None)
    return replace(base, prbs=prbs, excitation=excitation)


@cache
def unit_config(unit: str) -> PmrConfig:
    """The unit's shipped configuration (its own model, noise, PRBS, dither and MPC tuning).

    Raises
    ------
    ValueError
        ``unit`` is none of :func:`all_units`.
    """
    if unit in ROUTINE_UNITS:
        return _routine(unit)
    if unit not in UNITS:
        raise ValueError(f"unknown unit {unit!r}; choose one of {', '.join(all_units())}")
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
