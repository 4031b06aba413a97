"""Hard systems for the parametric method, and how its verdicts on them are scored against the truth.

Each :class:`HardCase` is a closed loop (a model, the shipped MPC with its
settings, PRBS setpoints, a plant with or without an injected mismatch) that
is hard in one way a real controller is:

* ``ogunnaike_ray``: the Ogunnaike-Ray 3x3 distillation column (Ogunnaike,
  Lemaire, Morari & Ray 1983) with each element reduced to FOPTD (whole-minute
  delays; G33's lead-lag to one lag): gains span four orders of magnitude
  (u3 barely moves y1 and y2), and the MPC moves u1 and u2 together
  (correlation about 0.95).  Input limits widened so that nothing saturates
  (saturation is its own case);
* ``skogestad_lv``: the LV distillation column (Skogestad, Morari & Doyle
  1988; condition number 142), time constants shortened to 15 min and
  delays added: both inputs move nearly in lockstep;
* ``near_zero_gain``: the well-conditioned 3x3 of ``config/three_by_three.yaml``
  with G12's model gain 1e-6 (an element that is, in effect, empty); limits
  widened as above.

:func:`score` counts per element parameter (gain, time constant, delay) the
*confidently wrong* verdicts -- ``mismatch`` on a parameter that did not
change, ``ok`` on one that changed by more than twice its tolerance, a
``mismatch`` of the wrong sign, a decisive delay other than the true one --,
the intervals that cover the truth among the parameters that are not
inconclusive, and the inconclusive ones.
"""

from __future__ import annotations

import tempfile
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import yaml
from simulated import diagnose_record

from pmr_ros.config import PmrConfig, load_config
from pmr_ros.core.results import Diagnosis
from pmr_ros.core.sim.closed_loop import simulate

WIDE_LIMITS = {"u_min": -20.0, "u_max": 20.0, "du_max": 5.0}
"""MPC input limits far outside what the setpoints ask for (mpc.u_min, u_max, du_max)."""


@dataclass(frozen=True)
class HardCase:
    """One hard closed loop: its params-file blocks and the mismatch injected in the ``full`` scenario.

    Attributes
    ----------
    name : str
    blocks : dict
        ``system``, ``mpc``, ``prbs``, ... blocks (without ``mismatch``).
    mismatch : dict
        The ``mismatch`` block (row-major matrices).
    samples : int
        Closed-loop samples per run.
    """

    name: str
    blocks: dict
    mismatch: dict
    samples: int = 8192
    notes: str = field(default="")

    def config(self) -> PmrConfig:
        """The configuration, loaded through a params file as a user would give it."""
        tree = {**self.blocks, "mismatch": self.mismatch}
        folder = Path(tempfile.mkdtemp(prefix="hard_case_"))
        path = folder / f"{self.name}.yaml"
        path.write_text(yaml.safe_dump({"/**": {"ros__parameters": tree}}))
        return load_config(path)


def _system(name: str, gain: list, tau: list, delay: list) -> dict:
    n_out = n_in = int(round(len(gain) ** 0.5))
    return {
        "name": name,
        "sample_time": 1.0,
        "output_names": [f"y{i + 1}" for i in range(n_out)],
        "input_names": [f"u{k + 1}" for k in range(n_in)],
        "gain": gain,
        "time_constant": tau,
        "delay": delay,
    }


def _limits(n: int) -> dict:
    return {key: [value] * n for key, value in WIDE_LIMITS.items()}


OGUNNAIKE_RAY = HardCase(
    "ogunnaike_ray",
    {
        "system": _system(
            "ogunnaike_ray",
            [0.66, -0.61, -0.0049, 1.11, -2.36, -0.01, -34.68, 46.2, 0.87],
            [6.7, 8.64, 9.06, 3.25, 5.0, 7.09, 8.15, 10.9, 11.08],
            [3.0, 4.0, 1.0, 7.0, 3.0, 1.0, 9.0, 9.0, 1.0],
        ),
        "mpc": _limits(3),
    },
    {
        "gain_pct": [15.0, 0.0, 0.0, 0.0, -10.0, 0.0, 0.0, 12.0, 0.0],
        "time_constant_pct": [0.0, 12.0, 0.0, -15.0, 0.0, 0.0, 0.0, 0.0, 10.0],
        "delay_samples": [0, 0, 0, 1, 0, 0, 0, 0, 1],
    },
)

SKOGESTAD_LV = HardCase(
    "skogestad_lv",
    {
        "system": _system("skogestad_lv", [0.878, -0.864, 1.082, -1.096], [15.0] * 4, [1.0, 2.0, 2.0, 1.0]),
        "mpc": _limits(2),
    },
    {
        "gain_pct": [10.0, 0.0, 0.0, -10.0],
        "time_constant_pct": [0.0, 15.0, 0.0, 0.0],
        "delay_samples": [0, 0, 1, 0],
    },
)

NEAR_ZERO_GAIN = HardCase(
    "near_zero_gain",
    {
        "system": _system(
            "near_zero_gain",
            [2.0, 1e-6, 1.4, 1.5, 2.4, -1.8, -1.4, 1.6, 2.2],
            [10.0, 12.0, 14.0, 15.0, 13.0, 11.0, 9.0, 12.0, 10.0],
            [2.0, 1.0, 3.0, 4.0, 2.0, 1.0, 2.0, 3.0, 1.0],
        ),
        "mpc": _limits(3),
    },
    {
        "gain_pct": [10.0, 0.0, -12.0, 0.0, 15.0, 0.0, -10.0, 0.0, 12.0],
        "time_constant_pct": [0.0, 0.0, 0.0, -12.0, 0.0, 12.0, 0.0, -12.0, 0.0],
        "delay_samples": [0, 0, 1, 2, 0, 0, 0, 1, 0],
    },
)

CASES = {case.name: case for case in (OGUNNAIKE_RAY, SKOGESTAD_LV, NEAR_ZERO_GAIN)}
"""The hard cases by name."""


def run(case: HardCase, seed: int, *, mismatch: bool, config: PmrConfig | None = None) -> Diagnosis:
    """The parametric diagnosis of one closed-loop run of ``case`` (``full`` or ``none`` scenario)."""
    config = config or case.config()
    record = simulate(config, samples=case.samples, seed=seed, scenario="full" if mismatch else "none")
    return diagnose_record(record, config, method="parametric", with_dither=True)


@dataclass
class Score:
    """Counts over element parameters (gain, time constant, delay) of modeled elements.

    Attributes
    ----------
    verdicts : int
        Parameter verdicts scored.
    wrong : int
        Confidently wrong ones (module docstring).
    inconclusive : int
    intervals, covered : int
        Intervals of parameters that are not inconclusive, and those that cover the truth.
    intervals_all, covered_all : int
        The same over every parameter with an interval, inconclusive or not (the intervals' own calibration).
    wrong_examples : list of str
    """

    verdicts: int = 0
    wrong: int = 0
    inconclusive: int = 0
    intervals: int = 0
    covered: int = 0
    intervals_all: int = 0
    covered_all: int = 0
    wrong_examples: list = field(default_factory=list)

    def add(self, other: Score) -> None:
        """Add another score's counts to this one."""
        self.verdicts += other.verdicts
        self.wrong += other.wrong
        self.inconclusive += other.inconclusive
        self.intervals += other.intervals
        self.covered += other.covered
        self.intervals_all += other.intervals_all
        self.covered_all += other.covered_all
        self.wrong_examples.extend(other.wrong_examples)


def _wrong(verdict: str, estimate: float, truth: float, tolerance: float) -> bool:
    """Whether a decisive verdict on a parameter with true change ``truth`` is confidently wrong."""
    if verdict == "mismatch":
        return truth == 0.0 or np.sign(estimate) != np.sign(truth)
    return verdict == "ok" and abs(truth) > 2.0 * tolerance


def _parameter(score: Score, label: str, verdict: str | None, estimate, interval, truth: float, tolerance: float):
    if verdict is None:
        return
    score.verdicts += 1
    if interval is not None:
        score.intervals_all += 1
        score.covered_all += int(interval[0] <= truth <= interval[1])
    if verdict == "inconclusive":
        score.inconclusive += 1
        return
    if _wrong(verdict, float(estimate), truth, tolerance):
        score.wrong += 1
        score.wrong_examples.append(f"{label}: {verdict} {estimate:+.1f} (truth {truth:+.1f})")
    if interval is not None:
        score.intervals += 1
        score.covered += int(interval[0] <= truth <= interval[1])


def score(diagnosis: Diagnosis, config: PmrConfig, *, mismatch: bool) -> Score:
    """Score the verdicts of every modeled element of ``diagnosis`` against the injected mismatch."""
    truth = config.mismatch.for_scenario("full" if mismatch else "none")
    settings = config.parametric
    out = Score()
    for name, element in diagnosis.elements.items():
        p = element.parametric
        if element.model.kind == "none" or p is None:
            continue
        i, k = element.row, element.column
        _parameter(
            out,
            f"{name} gain",
            p.gain_verdict,
            p.gain_mismatch_pct,
            p.gain_mismatch_pct_interval,
            float(truth.gain_pct[i, k]),
            settings.gain_tolerance_pct,
        )
        _parameter(
            out,
            f"{name} tau",
            p.tau_verdict,
            p.tau_mismatch_pct,
            p.tau_mismatch_pct_interval,
            float(truth.time_constant_pct[i, k]),
            settings.tau_tolerance_pct,
        )
        if p.delay_verdict is not None:
            out.verdicts += 1
            if p.delay_verdict == "inconclusive":
                out.inconclusive += 1
            elif p.delay_mismatch_samples != int(truth.delay_samples[i, k]):
                out.wrong += 1
                out.wrong_examples.append(
                    f"{name} delay: {p.delay_mismatch_samples:+d} (truth {truth.delay_samples[i, k]:+d})"
                )
    return out
