"""Shared cases of the routine-operation tests: Wood-Berry with a measured feed-rate DV and x_B in a zone."""

from __future__ import annotations

import numpy as np

from pmr_ros.core.results import ParametricResult

FEED_RATE_ZONE = {
    "system": {
        "disturbance_names": ["feed_rate"],
        "disturbance_gain": [3.8, 4.9],
        "disturbance_time_constant": [14.9, 13.2],
        "disturbance_delay": [8.0, 3.0],
    },
    "disturbance_signal": {"amplitude": 0.5, "mean_interval_samples": 150.0},
    "prbs": {"mode": "steps", "step_interval_samples": 200.0},
    "mpc": {"output_mode": ["setpoint", "zone"], "output_low": [-np.inf, -1.0], "output_high": [np.inf, 1.0]},
}
"""Overrides of the shipped Wood-Berry: one DV (feed rate) fed forward, x_D at its setpoint, x_B in [-1, 1],
setpoint steps every 200 samples on average."""


def gain_only_fit(gain_pct: float, *, mismatch: bool, half_width_pct: float) -> ParametricResult:
    """A parametric result that estimates ``gain_pct`` [%] within +-``half_width_pct`` [%] and nothing else.

    ``mismatch`` decides the gain's verdict (a verdict of 0 % is a mismatch whose impact must be exactly 1):
    a verdict to close the loop on without a diagnosis.
    """
    verdict = "mismatch" if mismatch else "ok"
    return ParametricResult(
        gain_mismatch_pct=gain_pct,
        gain_mismatch_pct_interval=(gain_pct - half_width_pct, gain_pct + half_width_pct),
        tau_mismatch_pct=0.0,
        tau_mismatch_pct_interval=(-half_width_pct, half_width_pct),
        delay_mismatch_samples=0,
        delay_confidence=0.99,
        gain_verdict=verdict,
        tau_verdict="ok",
        delay_verdict="ok",
    )
