"""Saturation and coloured disturbances over seeds: is the diagnosis ever confidently wrong? (prints a table).

Cases on the Wood-Berry column (``config/wood_berry.yaml``), each with and without the paper's
mismatch (``run.scenario`` full / none):

* ``baseline``: as shipped (white measurement noise 0.1, limits +/- 2 that never bind), for comparison;
* ``saturation``: u1's limits tightened to [-0.45, +0.45] so that it sits at a limit about 30 % of
  the samples (the setpoints and the MPC as shipped);
* ``disturbance``: the issue's unmeasured output disturbance on both outputs -- white noise through
  1/(1 - 0.97 z^-1), standard deviation 0.3 -- on top of the white measurement noise 0.1;
* ``strong_disturbance``: the same, four times as strong (1.2).

Printed per case, over the seeds: the parametric method's confidently-wrong share of element
diagnoses (a ``mismatch`` on a parameter that did not change, ``ok`` on one that changed by more
than twice its tolerance, or a mismatch of the wrong sign), the coverage of its 95 % intervals
(gain and time constant of the elements that are not inconclusive, and of all elements with numbers),
the inconclusive share of the
elements, and the classic method's false-alarm rate (a flag on a property that did not change) and
miss rate; then the data-quality figures (the saturated share of u1, the low-frequency ratio of each
output's residual) and how often their warnings appeared.  The test ``test/test_disturbance.py``
runs a reduced version with binomial bounds.

Run: .venv/bin/python benchmarks/bench_disturbance.py [--seeds 20] [--samples 16384] [--cases saturation,disturbance]
"""

from __future__ import annotations

import argparse
import os
import platform
import time
from collections.abc import Sequence
from dataclasses import dataclass, field, replace

import numpy as np

from pmr_ros.config import PmrConfig, config_dir, load_config
from pmr_ros.core.pmr.diagnosis import diagnose_stretches
from pmr_ros.core.records import Record
from pmr_ros.core.results import Diagnosis, ElementDiagnosis
from pmr_ros.core.sim.batch import simulate_many
from pmr_ros.core.sim.model import Mismatch
from pmr_ros.core.sim.true_plant import OutputDisturbance

CASES = ("baseline", "saturation", "disturbance", "strong_disturbance")
"""The hard cases of this benchmark."""

SATURATION_LIMIT = 0.45
"""u1's tightened limits, +/- [input unit]: about 30 % of u1's samples at one of them (Wood-Berry, shipped PRBS)."""

DISTURBANCE_STD, DISTURBANCE_POLE = 0.3, 0.97
"""The issue's coloured output disturbance: std 0.3 (its own), white noise through 1/(1 - pole z^-1)."""

STRONG_DISTURBANCE_STD = 1.2
"""Four times the issue's: where the method's limits show."""


def case_config(case: str, base: PmrConfig | None = None) -> PmrConfig:
    """The configuration of ``case`` (one of :data:`CASES`): Wood-Berry as shipped, made hard.

    Parameters
    ----------
    case : str
    base : PmrConfig, optional
        The configuration to start from (default ``config/wood_berry.yaml``).
    """
    config = base if base is not None else load_config(config_dir() / "wood_berry.yaml")
    n_out = config.model.n_outputs
    if case == "baseline":
        return config
    if case == "saturation":
        u_min, u_max = config.mpc.u_min.copy(), config.mpc.u_max.copy()
        u_min[0], u_max[0] = -SATURATION_LIMIT, SATURATION_LIMIT
        limits = {"u_min": u_min, "u_max": u_max}
        return replace(config, mpc=replace(config.mpc, **limits), quality=replace(config.quality, **limits))
    if case in ("disturbance", "strong_disturbance"):
        std = DISTURBANCE_STD if case == "disturbance" else STRONG_DISTURBANCE_STD
        return replace(config, disturbance=OutputDisturbance(np.full(n_out, std), DISTURBANCE_POLE))
    raise ValueError(f"unknown case {case!r}; choose one of {', '.join(CASES)}")


@dataclass
class Score:
    """Counts over element diagnoses of one case and scenario.

    Attributes
    ----------
    elements : int
        Element diagnoses scored.
    confidently_wrong : int
        Parametric element diagnoses with a confidently wrong parameter verdict.
    inconclusive : int
        Parametric element diagnoses that are inconclusive.
    covered, intervals : int
        Gain and time-constant intervals of conclusive elements that hold the truth, and how many there were.
    covered_all, intervals_all : int
        The same over every element with numbers, inconclusive or not: the intervals' own calibration, which
        the conclusive ones alone do not show (a decisive verdict is selected by its interval).
    classic_false_alarms, classic_unchanged : int
        Classic flags on properties that did not change, and how many such properties there were.
    classic_misses, classic_changed : int
        Classic properties that changed by more than twice the parametric tolerance but were not flagged, and
        how many there were.
    warnings : dict
        Count of element diagnoses carrying a warning that contains each key (``at a limit``, ``low-frequency``).
    """

    elements: int = 0
    confidently_wrong: int = 0
    inconclusive: int = 0
    covered: int = 0
    intervals: int = 0
    covered_all: int = 0
    intervals_all: int = 0
    classic_false_alarms: int = 0
    classic_unchanged: int = 0
    classic_misses: int = 0
    classic_changed: int = 0
    warnings: dict[str, int] = field(default_factory=dict)

    def add(self, other: Score) -> None:
        """Add ``other``'s counts to these."""
        for name in (
            "elements",
            "confidently_wrong",
            "inconclusive",
            "covered",
            "intervals",
            "covered_all",
            "intervals_all",
        ):
            setattr(self, name, getattr(self, name) + getattr(other, name))
        for name in ("classic_false_alarms", "classic_unchanged", "classic_misses", "classic_changed"):
            setattr(self, name, getattr(self, name) + getattr(other, name))
        for key, n in other.warnings.items():
            self.warnings[key] = self.warnings.get(key, 0) + n


WARNING_KEYS = ("at a limit", "low-frequency")
"""Substrings of the data-quality warnings counted per case."""


def _wrong(verdict: str | None, estimate: float | None, truth: float, tolerance: float) -> bool:
    """Whether a parameter verdict is confidently wrong (see the module docstring)."""
    if verdict == "mismatch":
        return truth == 0 or (estimate is not None and np.sign(estimate) != np.sign(truth))
    return verdict == "ok" and abs(truth) > 2 * tolerance


def _covers(interval: Sequence[float] | None, truth: float) -> bool:
    return interval is not None and interval[0] <= truth <= interval[1]


def score_parametric(diagnosis: Diagnosis, truth: Mismatch, *, gain_tolerance: float, tau_tolerance: float) -> Score:
    """Score the parametric verdicts of one diagnosis against the injected mismatch.

    Parameters
    ----------
    diagnosis : Diagnosis
        A parametric diagnosis of a FOPTD model.
    truth : Mismatch
        The injected mismatch [%, %, samples].
    gain_tolerance, tau_tolerance : float
        The parametric tolerances [%] (``parametric.gain_tolerance_pct``, ``tau_tolerance_pct``).
    """
    score = Score()
    for e in diagnosis:
        p = e.parametric
        score.elements += 1
        for key in WARNING_KEYS:
            score.warnings[key] = score.warnings.get(key, 0) + int(any(key in w for w in e.warnings))
        if p is None:
            score.inconclusive += 1
            continue
        dk, dt, dd = (
            float(truth.gain_pct[e.row, e.column]),
            float(truth.time_constant_pct[e.row, e.column]),
            int(truth.delay_samples[e.row, e.column]),
        )
        for interval, change in ((p.gain_mismatch_pct_interval, dk), (p.tau_mismatch_pct_interval, dt)):
            if interval is not None:
                score.intervals_all += 1
                score.covered_all += int(_covers(interval, change))
        if e.verdict == "inconclusive":
            score.inconclusive += 1
            continue
        wrong = _wrong(p.gain_verdict, p.gain_mismatch_pct, dk, gain_tolerance)
        wrong |= _wrong(p.tau_verdict, p.tau_mismatch_pct, dt, tau_tolerance)
        wrong |= p.delay_verdict in ("ok", "mismatch") and p.delay_mismatch_samples != dd
        score.confidently_wrong += int(wrong)
        score.covered += int(_covers(p.gain_mismatch_pct_interval, dk)) + int(_covers(p.tau_mismatch_pct_interval, dt))
        score.intervals += 2
    return score


def score_classic(diagnosis: Diagnosis, truth: Mismatch, *, gain_tolerance: float, tau_tolerance: float) -> Score:
    """Score the classic flags kept beside a diagnosis's verdicts (false alarms and misses per property).

    Parameters
    ----------
    diagnosis : Diagnosis
    truth : Mismatch
    gain_tolerance, tau_tolerance : float
        A change larger than twice these [%] counts as one a flag must find.
    """
    score = Score()
    for e in diagnosis:
        c = e.classic
        if c is None:
            continue
        changes = (
            float(truth.gain_pct[e.row, e.column]),
            float(truth.time_constant_pct[e.row, e.column]),
            float(truth.delay_samples[e.row, e.column]),
        )
        limits = (2 * gain_tolerance, 2 * tau_tolerance, 0.5)
        flags = (c.gain_mismatch, c.tau_mismatch, c.delay_mismatch)
        for change, limit, flag in zip(changes, limits, flags, strict=True):
            if change == 0:
                score.classic_unchanged += 1
                score.classic_false_alarms += int(flag)
            elif abs(change) > limit:
                score.classic_changed += 1
                score.classic_misses += int(not flag)
    return score


def run_case(config: PmrConfig, scenario: str, seeds: Sequence[int], samples: int) -> tuple[Score, list[Diagnosis]]:
    """Simulate ``seeds`` runs of ``scenario`` in lockstep, diagnose each (parametric), score them.

    Parameters
    ----------
    config : PmrConfig
        The case's configuration (:func:`case_config`).
    scenario : str
        ``full`` or ``none``.
    seeds : sequence of int
    samples : int
        Closed-loop samples per run.
    """
    truth = config.mismatch.for_scenario(scenario)
    records = simulate_many(config, [(scenario, s) for s in seeds], samples)
    total, diagnoses = Score(), []
    tolerances = {
        "gain_tolerance": config.parametric.gain_tolerance_pct,
        "tau_tolerance": config.parametric.tau_tolerance_pct,
    }
    for record in records:
        d = diagnose_stretches(
            [Record(record.r, record.u, record.y, record.dither)],
            model=config.model,
            pmr=config.pmr,
            parametric=config.parametric,
            method="parametric",
            quality=config.quality,
        )
        diagnoses.append(d)
        total.add(score_parametric(d, truth, **tolerances))
        total.add(score_classic(d, truth, **tolerances))
    return total, diagnoses


def _pct(n: int, of: int) -> str:
    return f"{100 * n / of:5.1f} %" if of else "    -"


def _figure(element: ElementDiagnosis, name: str) -> float:
    value = None if element.data_quality is None else getattr(element.data_quality, name)
    return np.nan if value is None else float(value)


def _figures(diagnoses: list[Diagnosis]) -> str:
    """Median and range of the saturated share of u1 and of each output's low-frequency ratio."""
    first = [d for d in diagnoses if d.status == "ok"]
    if not first:
        return "-"
    sat = [_figure(d.elements["G11"], "saturated_share") for d in first]
    low_arr = np.array([[_figure(e, "low_frequency_ratio") for e in d if e.column == 0] for d in first])
    rows = ", ".join(
        f"y{i + 1} {np.median(low_arr[:, i]):.3g} [{low_arr[:, i].min():.3g}, {low_arr[:, i].max():.3g}]"
        for i in range(low_arr.shape[1])
    )
    return f"u1 saturated {100 * np.median(sat):.1f} % [{100 * min(sat):.1f}, {100 * max(sat):.1f}]; low-freq {rows}"


def main(argv: list[str] | None = None) -> int:
    """Print the table."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n", 1)[0])
    parser.add_argument("--seeds", type=int, default=20)
    parser.add_argument("--samples", type=int, default=16384)
    parser.add_argument("--cases", default=",".join(CASES))
    parser.add_argument("--scenarios", default="none,full")
    args = parser.parse_args(argv)
    seeds = list(range(1, args.seeds + 1))
    print(
        f"{platform.node()}: {os.cpu_count()} cores, load {os.getloadavg()[0]:.1f}; {args.seeds} seeds, "
        f"{args.samples} samples, Wood-Berry, parametric method (classic flags beside it)"
    )
    head = (
        f"{'case':12s} {'scenario':8s} {'conf. wrong':>11s} {'coverage':>9s} {'(all)':>7s} {'inconcl.':>9s} "
        f"{'classic false alarms':>21s} {'classic misses':>15s} {'warned: limit / low-freq':>25s}  time"
    )
    print(head)
    for case in args.cases.split(","):
        config = case_config(case)
        for scenario in args.scenarios.split(","):
            t0 = time.perf_counter()
            s, diagnoses = run_case(config, scenario, seeds, args.samples)
            elapsed = time.perf_counter() - t0
            warned = " / ".join(_pct(s.warnings.get(k, 0), s.elements) for k in WARNING_KEYS)
            print(
                f"{case:12s} {scenario:8s} {_pct(s.confidently_wrong, s.elements):>11s} "
                f"{_pct(s.covered, s.intervals):>9s} {_pct(s.covered_all, s.intervals_all):>7s} "
                f"{_pct(s.inconclusive, s.elements):>9s} "
                f"{_pct(s.classic_false_alarms, s.classic_unchanged):>21s} "
                f"{_pct(s.classic_misses, s.classic_changed):>15s} {warned:>25s}  {elapsed:.0f} s"
            )
            print(f"{'':21s} {_figures(diagnoses)}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
