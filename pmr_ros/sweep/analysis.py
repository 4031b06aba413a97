"""Reduce the sweep's CSV: medians over seeds, correctness, breakdown points.

Correct diagnosis of one run and element (what "right" means here):

* gain: ``|estimated K/Khat - true K/Khat| <= GAIN_TOLERANCE`` (3 percentage points;
  the estimate is the classic ``gain_ratio`` M(0), or ``1 + gain_mismatch_pct/100`` of the parametric fit);
* time constant: with a time-constant mismatch injected, the classic flag is
  raised and the index has the sign of the mismatch; without one, the flag is
  not raised (``|tau index| <= pmr.tau_index_threshold``);
* delay: the estimated delay mismatch equals the injected one, in samples.

For the parametric method, which estimates the time constant itself, the time
constant is right when ``|dtau % - injected dtau %| <= TAU_TOLERANCE_PCT``
(5 percentage points) -- the target of the parametric method.

A run whose diagnosis has no numbers (insufficient data) is wrong on all three.
A point (sweep, nu, scenario, element, diagnosis) *fails* when more than half
of its seeds are wrong.  The breakdown nu of a diagnosis is the smallest nu of
the grid at which its point fails, provided it does not fail at the first
(baseline) nu already.
"""

from __future__ import annotations

from collections import defaultdict
from dataclasses import dataclass

import numpy as np

GAIN_TOLERANCE = 0.03
"""Largest |estimated - true| gain ratio counted as right (3 percentage points)."""

TAU_TOLERANCE_PCT = 5.0
"""Largest |fitted - injected| time-constant change counted as right for the parametric method [pp]."""

DIAGNOSES = ("gain", "tau", "delay")


def gain_ratio_value(row: dict) -> float | None:
    """The row's estimate of K/Khat: the classic ``gain_ratio``, or ``1 + gain_mismatch_pct/100`` (parametric)."""
    if row.get("method") != "parametric":
        return row["gain_ratio"]
    change = row.get("gain_mismatch_pct")
    return None if change is None else 1.0 + change / 100.0


def tau_value(row: dict) -> float | None:
    """The row's time-constant estimate: the classic index, or the parametric dtau %."""
    return row.get("tau_mismatch_pct") if row.get("method") == "parametric" else row["tau_index"]


def run_correctness(row: dict, tau_threshold: float) -> dict[str, bool]:
    """Whether each diagnosis of one CSV row (one run, one element) is right."""
    gain = gain_ratio_value(row)
    if row["status"] != "ok" or gain is None:
        return dict.fromkeys(DIAGNOSES, False)
    gain_ok = abs(gain - row["true_gain_ratio"]) <= GAIN_TOLERANCE + 1e-12
    truth = row["true_time_constant_pct"]
    if row.get("method") == "parametric":
        fitted = row.get("tau_mismatch_pct")
        tau_ok = fitted is not None and abs(fitted - truth) <= TAU_TOLERANCE_PCT + 1e-12
        delay_ok = row["delay_mismatch_samples"] == row["true_delay_samples"]
        return {"gain": bool(gain_ok), "tau": bool(tau_ok), "delay": bool(delay_ok)}
    index = row["tau_index"]
    if index is None:  # no time-constant index (the classic method on a tf or step_response element)
        tau_ok = False
    elif truth != 0:
        tau_ok = abs(index) > tau_threshold and np.sign(index) == np.sign(truth)
    else:
        tau_ok = abs(index) <= tau_threshold
    delay_ok = row["delay_mismatch_samples"] == row["true_delay_samples"]
    return {"gain": bool(gain_ok), "tau": bool(tau_ok), "delay": bool(delay_ok)}


@dataclass(frozen=True)
class PointSummary:
    """One (method, sweep, nu, scenario, element) over its seeds.

    ``*_median/_low/_high`` are the median, minimum and maximum over seeds;
    ``*_wrong`` the number of seeds whose diagnosis is wrong.
    """

    method: str
    sweep: str
    element_swept: str
    nu: float
    scenario: str
    element: str
    seeds: int
    row_time_constant_ratio: float
    prediction_horizon: int
    loop_spectral_radius: float
    true_gain_ratio: float
    true_time_constant_pct: float
    true_delay_samples: int
    gain_median: float
    gain_low: float
    gain_high: float
    tau_median: float
    tau_low: float
    tau_high: float
    delay_median: float
    delay_low: float
    delay_high: float
    gain_wrong: int
    tau_wrong: int
    delay_wrong: int
    insufficient: int
    solve_fraction: float
    mpc_failures: int
    tracking_rms: float

    def fails(self, diagnosis: str) -> bool:
        """More than half of the seeds wrong."""
        return getattr(self, f"{diagnosis}_wrong") > self.seeds / 2


def _stats(values: list) -> tuple[float, float, float]:
    v = np.array([x for x in values if x is not None], dtype=float)
    if v.size == 0:
        return (float("nan"),) * 3
    return float(np.median(v)), float(v.min()), float(v.max())


def summarize(rows: list[dict], tau_threshold: float) -> list[PointSummary]:
    """One :class:`PointSummary` per (method, sweep, nu, scenario, element), sorted."""
    groups: dict[tuple, list[dict]] = defaultdict(list)
    for row in rows:
        groups[
            (row["method"], row["sweep"], row["element_swept"], round(row["nu"], 9), row["scenario"], row["element"])
        ].append(row)
    return [_point_summary(key, groups[key], tau_threshold) for key in sorted(groups)]


def _point_summary(key: tuple, g: list[dict], tau_threshold: float) -> PointSummary:
    """The summary of one group's runs (the seeds of one point, scenario and element)."""
    right = [run_correctness(r, tau_threshold) for r in g]
    first = g[0]
    gm, gl, gh = _stats([gain_ratio_value(r) for r in g])
    tm, tl, th = _stats([tau_value(r) for r in g])
    dm, dl, dh = _stats([r["delay_mismatch_samples"] for r in g])
    return PointSummary(
        method=key[0],
        sweep=key[1],
        element_swept=key[2],
        nu=key[3],
        scenario=key[4],
        element=key[5],
        seeds=len(g),
        row_time_constant_ratio=first["row_time_constant_ratio"],
        prediction_horizon=first["prediction_horizon"],
        loop_spectral_radius=first["loop_spectral_radius"],
        true_gain_ratio=first["true_gain_ratio"],
        true_time_constant_pct=first["true_time_constant_pct"],
        true_delay_samples=first["true_delay_samples"],
        gain_median=gm,
        gain_low=gl,
        gain_high=gh,
        tau_median=tm,
        tau_low=tl,
        tau_high=th,
        delay_median=dm,
        delay_low=dl,
        delay_high=dh,
        gain_wrong=sum(not c["gain"] for c in right),
        tau_wrong=sum(not c["tau"] for c in right),
        delay_wrong=sum(not c["delay"] for c in right),
        insufficient=sum(r["status"] != "ok" for r in g),
        solve_fraction=float(np.mean([r["mpc_solves"] / r["samples"] for r in g])),
        mpc_failures=int(sum(r["mpc_failures"] for r in g)),
        tracking_rms=float(np.median([r["tracking_rms"] for r in g])),
    )


@dataclass(frozen=True)
class Breakdown:
    """Where one diagnosis of one element breaks down in one sweep and scenario.

    Attributes
    ----------
    nu : float or None
        First nu of the grid at which the point fails; None if it never fails.
    ratio : float or None
        The row time-constant ratio at ``nu``.
    failing_share : float
        Share of the grid points at ``nu`` and above that fail (1 = stays broken).
    fails_at_baseline : bool
        The point already fails at the first nu of the grid (then ``nu`` is None).
    """

    method: str
    sweep: str
    element_swept: str
    element: str
    diagnosis: str
    scenario: str
    nu: float | None
    ratio: float | None
    failing_share: float
    fails_at_baseline: bool


def breakdowns(summary: list[PointSummary]) -> list[Breakdown]:
    """The :class:`Breakdown` of every (method, sweep, element, diagnosis, scenario)."""
    series: dict[tuple, list[PointSummary]] = defaultdict(list)
    for p in summary:
        series[(p.method, p.sweep, p.element_swept, p.element, p.scenario)].append(p)
    out = []
    for (method, sweep, swept, element, scenario), points in sorted(series.items()):
        points = sorted(points, key=lambda p: p.nu)
        for diagnosis in DIAGNOSES:
            fails = [p.fails(diagnosis) for p in points]
            at_baseline = fails[0]
            first = next((j for j, f in enumerate(fails) if f), None) if not at_baseline else None
            share = float(np.mean(fails[first:])) if first is not None else 0.0
            out.append(
                Breakdown(
                    method,
                    sweep,
                    swept,
                    element,
                    diagnosis,
                    scenario,
                    points[first].nu if first is not None else None,
                    points[first].row_time_constant_ratio if first is not None else None,
                    share,
                    at_baseline,
                )
            )
    return out


def earliest(items: list[Breakdown]) -> Breakdown | None:
    """The breakdown with the smallest nu among ``items`` (None if none breaks down)."""
    broken = [(b.nu, b) for b in items if b.nu is not None]
    return min(broken, key=lambda pair: pair[0])[1] if broken else None
