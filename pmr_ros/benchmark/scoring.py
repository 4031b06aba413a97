"""Scoring: every method's per-element results against the injected truth, per method, unit, disturbance and length.

The numbers, each over the modelled elements of a group of runs (an element
a method returned nothing for counts as not detected and inconclusive):

* ``detection``, ``false_alarm``: the method's own verdict (``detected``) on
  the mismatched and on the clean elements;
* ``detection_at_1``, ``detection_at_5``: detection when the threshold on the
  method's evidence (its score, larger is stronger) is set on the clean
  elements of the group so that at most 1 % (5 %) of them exceed it
  (:func:`threshold_at`); ``detection_at_1_big``: the same on the elements
  with |dK| >= 10 %.  A method without a score has NaN evidence: never
  detected this way.  With ``n`` clean elements a rate below ``1 / n`` means
  "above every clean element"; with none the three are NaN;
* ``localisation``: the share of runs whose set of detected elements is exactly the set of mismatched ones;
* ``gain_error``, ``tau_error``: median |estimate - truth| [percentage points]
  where the method quantifies; ``delay_exact``: the share of delay estimates
  equal to the injected dD;
* ``gain_coverage``, ``tau_coverage``: the share of finite intervals that hold the truth;
* ``inconclusive``: the share of elements with that verdict;
* ``cpu_s``: median CPU time of one diagnosis of a run [s].
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    import pandas as pd  # annotations only: pandas is the data extra, imported where used

__all__ = ["BIG_GAIN_PCT", "GROUP", "label_results", "roc_points", "roc_table", "score", "threshold_at"]

GROUP = ["method", "unit", "disturbance", "samples"]
"""What a line of the score table is per."""

BIG_GAIN_PCT = 10.0
"""``detection_at_1_big`` counts the mismatched elements with at least this |dK| [%]."""

TRUTH = ["gain_pct", "tau_pct", "delay_samples"]


def label_results(results: pd.DataFrame, labels: pd.DataFrame) -> pd.DataFrame:
    """Every (method, labelled element of a run the method ran on) with its result and the truth (``true_`` columns).

    Parameters
    ----------
    results : DataFrame
        Rows of :func:`pmr_ros.benchmark.runner.method_rows` (run, method, element, detected, ...).
    labels : DataFrame
        Scenario lines (run, unit, samples, disturbance, element, gain_pct, tau_pct, delay_samples) of the runs scored.
    """
    truth = labels[["run", "unit", "samples", "disturbance", "element", *TRUTH]].rename(
        columns={c: f"true_{c}" for c in TRUTH}
    )
    ran = results[["run", "method"]].drop_duplicates()  # a method is scored on the runs it ran on only
    grid = truth.merge(ran, on="run")
    out = grid.merge(results, on=["run", "method", "element"], how="left")
    out["detected"] = out["detected"].eq(True)  # a missing result is not a detection
    out["verdict"] = out["verdict"].fillna("inconclusive")
    out["mismatched"] = (out[[f"true_{c}" for c in TRUTH]] != 0).any(axis=1)
    return out


def threshold_at(clean_evidence: np.ndarray, rate: float) -> float:
    """The smallest threshold that at most ``floor(rate x n)`` of the ``n`` clean elements' evidence exceeds.

    NaN evidence never exceeds a threshold; with no clean element the threshold is +inf (nothing detected).

    Examples
    --------
    >>> threshold_at(np.arange(100.0), 0.05)
    94.0
    """
    values = np.sort(np.nan_to_num(np.asarray(clean_evidence, dtype=float), nan=-np.inf))[::-1]
    if values.size == 0:
        return math.inf
    allowed = int(math.floor(rate * values.size + 1e-9))
    return -math.inf if allowed >= values.size else float(values[allowed])


def roc_points(evidence: np.ndarray, mismatched: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """False-alarm and detection rates at every threshold on ``evidence`` (NaN: never detected), from (0, 0)."""
    score = np.nan_to_num(np.asarray(evidence, dtype=float), nan=-np.inf)
    truth = np.asarray(mismatched, dtype=bool)
    order = np.argsort(-score, kind="stable")
    score, truth = score[order], truth[order]
    keep = np.isfinite(score) & np.r_[score[1:] != score[:-1], True]  # last of each tie
    tp, fp = np.cumsum(truth)[keep], np.cumsum(~truth)[keep]
    n_pos, n_neg = max(int(truth.sum()), 1), max(int((~truth).sum()), 1)
    return np.r_[0.0, fp / n_neg], np.r_[0.0, tp / n_pos]


def _rate(mask: pd.Series) -> float:
    return float(mask.mean()) if mask.size else math.nan


def _exceed(evidence: pd.Series, threshold: float) -> float:
    """The share of ``evidence`` above ``threshold`` (NaN with no threshold or no element)."""
    return math.nan if math.isnan(threshold) else _rate(evidence > threshold)


def _median(values: pd.Series) -> float:
    values = values.dropna()
    return float(values.median()) if values.size else math.nan


def _detection(group: pd.DataFrame) -> dict[str, float]:
    bad, clean = group[group["mismatched"]], group[~group["mismatched"]]
    evidence = group["evidence"].fillna(-np.inf)
    out = {"detection": _rate(bad["detected"]), "false_alarm": _rate(clean["detected"])}
    for rate, name in ((0.01, "detection_at_1"), (0.05, "detection_at_5")):
        # no clean element: no false-alarm rate to hold, so no threshold (NaN, not 0)
        threshold = threshold_at(clean["evidence"].to_numpy(), rate) if len(clean) else math.nan
        out[name] = _exceed(evidence[bad.index], threshold)
        if rate == 0.01:
            big = bad.index[bad["true_gain_pct"].abs() >= BIG_GAIN_PCT]
            out["detection_at_1_big"] = _exceed(evidence[big], threshold)
    return out


def _localisation(group: pd.DataFrame) -> float:
    exact = (group["detected"] == group["mismatched"]).groupby(group["run"]).all()
    return _rate(exact)


def _quantification(group: pd.DataFrame) -> dict[str, float]:
    out = {
        "gain_error": _median((group["gain_pct"] - group["true_gain_pct"]).abs()),
        "tau_error": _median((group["tau_pct"] - group["true_tau_pct"]).abs()),
    }
    delays = group.dropna(subset=["delay_samples"])
    out["delay_exact"] = _rate(delays["delay_samples"] == delays["true_delay_samples"])
    for part in ("gain", "tau"):
        held = group.dropna(subset=[f"{part}_lo", f"{part}_hi"])
        held = held[np.isfinite(held[f"{part}_lo"]) & np.isfinite(held[f"{part}_hi"])]
        truth = held[f"true_{part}_pct"]
        out[f"{part}_coverage"] = _rate((held[f"{part}_lo"] <= truth) & (truth <= held[f"{part}_hi"]))
    return out


def _group_score(group: pd.DataFrame) -> dict[str, float]:
    cpu = group.drop_duplicates("run")["cpu_s"]
    return {
        "runs": float(group["run"].nunique()),
        "elements": float(len(group)),
        "mismatched": float(group["mismatched"].sum()),
        **_detection(group),
        "localisation": _localisation(group),
        **_quantification(group),
        "inconclusive": _rate(group["verdict"] == "inconclusive"),
        "cpu_s": _median(cpu),
    }


def score(labelled: pd.DataFrame, by: list[str] | None = None) -> pd.DataFrame:
    """The score table: one line per group of ``by`` (default :data:`GROUP`), the numbers of the module docstring.

    Parameters
    ----------
    labelled : DataFrame
        :func:`label_results`'s table.
    by : list of str, optional
        Columns to group by; ``method`` should be among them.
    """
    import pandas as pd

    by = GROUP if by is None else by
    lines = []
    for key, group in labelled.groupby(by, sort=True):
        values = key if isinstance(key, tuple) else (key,)
        lines.append({**dict(zip(by, values, strict=True)), **_group_score(group.reset_index(drop=True))})
    table = pd.DataFrame(lines)
    for column in ("runs", "elements", "mismatched"):
        if column in table:
            table[column] = table[column].astype(int)
    return table


def paired_scores(labelled: pd.DataFrame, *, ours: str = "parametric") -> pd.DataFrame:
    """Ours and each peer scored on the same runs: those of each group the peer diagnosed.

    A peer run on fewer runs than ours (the prediction-error fits on the first runs of each cell,
    ``--pem-runs-per-cell``) is compared with ours on those runs only, not with ours on all.

    Returns
    -------
    DataFrame
        :func:`score`'s lines of ``ours`` and of the peer on the peer's runs, with a ``peer`` column
        naming the peer of each pair.
    """
    import pandas as pd

    parts = []
    for peer in sorted(set(labelled["method"]) - {ours}):
        runs = labelled.loc[labelled["method"] == peer, "run"].unique()
        both = labelled[labelled["method"].isin([ours, peer]) & labelled["run"].isin(runs)]
        parts.append(score(both.reset_index(drop=True)).assign(peer=peer))
    return pd.concat(parts, ignore_index=True) if parts else pd.DataFrame(columns=[*GROUP, "peer"])


def roc_table(labelled: pd.DataFrame) -> pd.DataFrame:
    """The ROC points (:func:`roc_points`) of every group of :data:`GROUP` whose method has a score.

    Columns: the group's, then ``false_alarm`` and ``detection``, one line per point, from (0, 0).
    """
    import pandas as pd

    parts = []
    for key, group in labelled.groupby(GROUP, sort=True):
        if not np.isfinite(group["evidence"].to_numpy(dtype=float)).any():
            continue
        fa, det = roc_points(group["evidence"].to_numpy(), group["mismatched"].to_numpy())
        parts.append(pd.DataFrame({**dict(zip(GROUP, key, strict=True)), "false_alarm": fa, "detection": det}))
    return pd.concat(parts, ignore_index=True) if parts else pd.DataFrame(columns=[*GROUP, "false_alarm", "detection"])
