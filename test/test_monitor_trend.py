"""The trend table: one row per window and element, written as CSV and Parquet, and the onsets read from it."""

from __future__ import annotations

import json

import numpy as np
import pandas as pd
import pytest
from scipy.stats import norm

from pmr_ros.core.monitor import (
    ELEMENT_KEYS,
    onset_entries,
    trend_onsets,
    trend_table,
    window_plan,
    window_views,
    write_trend,
)
from pmr_ros.core.monitor.trend import delay_interval

DAYS, WINDOW = 120, 14
PLAN = window_plan(n_samples=DAYS, window=WINDOW, step=1)
Z = norm.ppf(0.975)


def _verdict(low: float, high: float, tolerance: float) -> str:
    if low > tolerance or high < -tolerance:
        return "mismatch"
    return "ok" if -2 * tolerance < low and high < 2 * tolerance else "inconclusive"


def _paths() -> dict[str, dict[str, np.ndarray]]:
    days = np.arange(DAYS)
    flat = np.zeros(DAYS)
    return {
        "G11": {"gain": np.clip((days - 50) / 10, 0, 1) * 15.0, "tau": flat, "delay": flat},  # gain drift from day 50
        "G12": {"gain": flat + 1.0, "tau": flat, "delay": 2.0 * (days >= 80)},  # delay step on day 80
        "G21": {"gain": flat, "tau": flat - 4.0, "delay": flat},  # no change
    }


ERRORS = {"gain": 0.5, "tau": 1.0, "delay": 0.2}
TOLERANCES = {"gain": 3.0, "tau": 5.0, "delay": 1.0}
KEYS = {"gain": "gain_mismatch_pct", "tau": "tau_mismatch_pct", "delay": "delay_mismatch_samples"}


def _windows(*, nested: bool) -> list[dict]:
    """Per-window results as mappings; ``nested``: G11 in the ``to_dict()`` shape (numbers under ``parametric``)."""
    rng = np.random.default_rng(4)
    estimates = {}
    for name, paths in _paths().items():
        for parameter, path in paths.items():
            daily = rng.standard_normal(DAYS) * ERRORS[parameter] * np.sqrt(WINDOW)
            noise = np.array([view.mean() for view in window_views(daily, PLAN)])
            means = np.array([view.mean() for view in window_views(path, PLAN)]) + noise
            # an integer delay is the window's mean delay rounded (trend.FOLLOW; measured on the year benchmark)
            estimates[name, parameter] = np.round(means) if parameter == "delay" else means
    windows = []
    for index, (first, last) in enumerate(PLAN):
        elements = {}
        for name in _paths():
            fields: dict = {}
            for parameter, key in KEYS.items():
                value, half = estimates[name, parameter][index], Z * ERRORS[parameter]
                fields[key], fields[f"{key}_interval"] = value, (value - half, value + half)
                fields[f"{parameter}_verdict"] = _verdict(value - half, value + half, TOLERANCES[parameter])
            verdicts = [fields[f"{p}_verdict"] for p in KEYS]
            verdict = "mismatch" if "mismatch" in verdicts else "inconclusive" if "inconclusive" in verdicts else "ok"
            quality = {"saturated_share": 0.01 * index, "warnings": ["none"]}
            if nested and name == "G11":
                elements[name] = {"element": name, "verdict": verdict, "parametric": fields, "data_quality": quality}
            else:
                elements[name] = {**fields, "verdict": verdict, "data_quality": quality}
        start = pd.Timestamp("2026-01-01", tz="UTC") + pd.Timedelta(days=first)
        end = pd.Timestamp("2026-01-01", tz="UTC") + pd.Timedelta(days=last + 1)
        windows.append(
            {"first": first, "last": last, "start": start.isoformat(), "end": end.isoformat()}
            | {"elements": elements, "quality": {"coherence": 0.9}}
        )
    return windows


def test_one_row_per_window_and_element_with_estimates_intervals_verdicts_and_quality():
    windows = _windows(nested=True)
    table = trend_table(windows)
    assert len(table) == len(PLAN) * 3
    assert list(table.columns[:7]) == ["window", "first", "last", "start", "end", "element", "verdict"]
    assert {"quality_coherence", "quality_saturated_share"} <= set(table.columns)
    assert "quality_warnings" not in table.columns
    for index in (0, 37, len(PLAN) - 1):
        for name, element in windows[index]["elements"].items():
            row = table[(table["window"] == index) & (table["element"] == name)].iloc[0]
            fields = element.get("parametric", element)
            assert (row["first"], row["last"], row["end"]) == (PLAN[index][0], PLAN[index][1], windows[index]["end"])
            assert row["verdict"] == element["verdict"]
            for parameter, key in KEYS.items():
                np.testing.assert_allclose(row[key], fields[key], rtol=1e-12)
                np.testing.assert_allclose([row[f"{key}_low"], row[f"{key}_high"]], fields[f"{key}_interval"])
                assert row[f"{parameter}_verdict"] == fields[f"{parameter}_verdict"]
            np.testing.assert_allclose(row["quality_saturated_share"], 0.01 * index)


def test_missing_fields_are_empty_cells_and_elements_may_come_as_a_list():
    table = trend_table([{"first": 0, "last": 9, "elements": [{"element": "G11", "verdict": "inconclusive"}]}])
    assert len(table) == 1 and table["element"].iloc[0] == "G11"
    assert np.isnan(table["gain_mismatch_pct"].iloc[0]) and np.isnan(table["delay_mismatch_samples_high"].iloc[0])
    assert table["tau_verdict"].iloc[0] is None and table["start"].iloc[0] is None
    assert all(key in ELEMENT_KEYS for key in ("verdict", "gain_mismatch_pct_interval", "delay_verdict"))
    empty = trend_table([])
    assert len(empty) == 0 and "gain_mismatch_pct_low" in empty.columns
    assert len(trend_onsets(empty, window=14.0)) == 0
    with pytest.raises(ValueError, match=r"windows\[0\]: no elements"):
        trend_table([{"first": 0, "last": 9}])


def test_an_elements_own_value_comes_first_and_its_parametric_parts_where_it_has_none():
    element = {
        "verdict": "ok",
        "gain_mismatch_pct": None,
        "tau_mismatch_pct": 2.0,
        "parametric": {"verdict": "mismatch", "gain_mismatch_pct": 5.0, "tau_mismatch_pct": 1.0, "tau_verdict": "ok"},
    }
    (row,) = trend_table([{"first": 0, "last": 9, "elements": {"G11": element}}]).to_dict(orient="records")
    assert (row["verdict"], row["gain_mismatch_pct"], row["tau_mismatch_pct"]) == ("ok", 5.0, 2.0)
    assert row["tau_verdict"] == "ok" and row["gain_verdict"] is None


@pytest.mark.parametrize("suffix", [".csv", ".parquet"])
def test_the_table_round_trips_through_csv_and_parquet(tmp_path, suffix):
    table = trend_table(_windows(nested=False))
    path = write_trend(table, tmp_path / f"trend{suffix}")
    back = pd.read_csv(path) if suffix == ".csv" else pd.read_parquet(path)
    pd.testing.assert_frame_equal(back, table, check_dtype=False, rtol=1e-12)


def test_a_trend_file_of_another_kind_is_one_clear_error(tmp_path):
    with pytest.raises(ValueError, match=r"--trend .*trend\.xlsx: the trend file must end in .csv or .parquet"):
        write_trend(trend_table([]), tmp_path / "trend.xlsx")


def test_onsets_from_the_table_find_the_drift_the_step_and_nothing_else():
    table = trend_table(_windows(nested=True))
    onsets = trend_onsets(table, window=WINDOW * 86400.0)
    assert len(onsets) == 9
    kinds = {(row.element, row.parameter): row.kind for row in onsets.itertuples()}
    assert kinds.pop(("G11", "gain")) == "drift"
    assert kinds.pop(("G12", "delay")) == "step"
    assert set(kinds.values()) == {"none"}
    start = pd.Timestamp("2026-01-01", tz="UTC").timestamp()
    found = onsets.set_index(["element", "parameter"])
    np.testing.assert_allclose((found.loc[("G11", "gain"), "onset"] - start) / 86400, 50, atol=3)
    np.testing.assert_allclose((found.loc[("G12", "delay"), "onset"] - start) / 86400, 80, atol=3)
    # the window from which the verdict stays mismatch: G11's gain beyond 3 % for good
    lasting = found.loc[("G11", "gain"), "lasting_mismatch_window"]
    verdicts = table[table["element"] == "G11"].sort_values("window")["verdict"].tolist()
    assert verdicts[lasting] == "mismatch" and verdicts[lasting - 1] != "mismatch"
    assert set(verdicts[lasting:]) == {"mismatch"}
    assert pd.isna(found.loc[("G21", "gain"), "lasting_mismatch_window"])  # dtau -4 % is within the tolerance
    step_lasting = found.loc[("G12", "delay"), "lasting_mismatch_window"]
    assert 80 - WINDOW <= step_lasting <= 80  # mismatch once about half the window has the new delay


def test_onsets_by_sample_index_when_the_data_have_no_clock():
    table = trend_table(_windows(nested=False)).drop(columns=["end"])
    onsets = trend_onsets(table, window=float(WINDOW), time="last").set_index(["element", "parameter"])
    # ends at the last sample: a day earlier than the window's end instant
    np.testing.assert_allclose(onsets.loc[("G12", "delay"), "onset"], 80 - 1, atol=3)


def test_a_parameter_without_intervals_takes_its_default_error():
    table = trend_table(_windows(nested=False))
    table[["delay_mismatch_samples_low", "delay_mismatch_samples_high"]] = np.nan  # dD has a value, no interval
    without = trend_onsets(table, window=WINDOW * 86400.0).set_index(["element", "parameter"])
    assert without.loc[("G12", "delay"), "kind"] == "insufficient"
    assert without.loc[("G12", "delay"), "windows"] == 0
    given = trend_onsets(table, window=WINDOW * 86400.0, default_errors={"delay": ERRORS["delay"]})
    found = given.set_index(["element", "parameter"]).loc[("G12", "delay")]
    start = pd.Timestamp("2026-01-01", tz="UTC").timestamp()
    assert found["kind"] == "step" and found["windows"] == len(PLAN)
    np.testing.assert_allclose((found["onset"] - start) / 86400, 80, atol=3)


def test_onset_entries_are_plain_json_per_element():
    onsets = trend_onsets(trend_table(_windows(nested=False)), window=WINDOW * 86400.0)
    entries = onset_entries(onsets)
    assert set(entries) == {"G11", "G12", "G21"}
    assert set(entries["G12"]) == {"lasting_mismatch_window", "gain", "tau", "delay"}
    back = json.loads(json.dumps(entries))
    row = onsets.set_index(["element", "parameter"]).loc[("G12", "delay")]
    assert back["G12"]["delay"]["kind"] == "step"
    np.testing.assert_allclose(back["G12"]["delay"]["interval"], [row["onset_low"], row["onset_high"]])
    np.testing.assert_allclose(back["G12"]["delay"]["onset"], row["onset"])
    assert back["G12"]["lasting_mismatch_window"] == row["lasting_mismatch_window"]
    assert back["G21"]["gain"] | {"level": None, "p_value": None} == {
        "kind": "none",
        "onset": None,
        "interval": None,
        "end": None,
        "size": None,
        "rate": None,
        "level": None,
        "p_value": None,
        "windows": len(PLAN),
    }
    assert back["G21"]["lasting_mismatch_window"] is None


def test_the_codecs_low_and_high_and_the_delays_own_interval():
    element = {
        "verdict": "mismatch",
        "parametric": {
            "gain_mismatch_pct": 12.0,
            "gain_mismatch_pct_low": 10.0,
            "gain_mismatch_pct_high": 14.0,
            "delay_mismatch_samples": 2,
            "delay_confidence": 0.99,
        },
    }
    unsure = {"verdict": "ok", "delay_mismatch_samples": 0, "delay_confidence": 0.6}
    table = trend_table([{"first": 0, "last": 9, "elements": {"G11": element, "G12": unsure}}])
    row, other = table.iloc[0], table.iloc[1]
    assert (row["gain_mismatch_pct_low"], row["gain_mismatch_pct_high"]) == (10.0, 14.0)
    assert (row["delay_mismatch_samples_low"], row["delay_mismatch_samples_high"]) == (1.5, 2.5)
    assert (other["delay_mismatch_samples_low"], other["delay_mismatch_samples_high"]) == (-1.5, 1.5)
    assert delay_interval(None, 0.99) is None and delay_interval(3, None) == (1.5, 4.5)


def _stepping_windows(seed: int) -> list[dict]:
    """Windows as the monitor gives them: dD an integer (the window's mean delay rounded) with its own interval.

    G11's gain drifts +20 % over 14 days from day 30, G12's gain steps +6 % on day 60, G21's delay steps +2
    samples on day 50 and G22's -3 on day 75; the rest stays put.
    """
    days = np.arange(DAYS)
    flat = np.zeros(DAYS)
    paths = {
        "G11": {"gain": 20.0 * np.clip((days + 0.5 - 30) / 14, 0, 1), "delay": flat},
        "G12": {"gain": 6.0 * (days >= 60), "delay": flat},
        "G21": {"gain": flat, "delay": 2.0 * (days >= 50)},
        "G22": {"gain": flat, "delay": -3.0 * (days >= 75)},
    }
    rng = np.random.default_rng(seed)
    # the year benchmark's windows chose their delay with a profile confidence of 0.998 or more, about
    # 0.1 samples of continuous error: the rounding's interval (+-0.5) is the delay's, as delay_interval's
    error = {"gain": ERRORS["gain"], "delay": 0.1}
    elements: dict[str, list[dict]] = {}
    for name, path in paths.items():
        noise = {p: rng.standard_normal(DAYS) * error[p] * np.sqrt(WINDOW) for p in path}
        mean = {p: np.array([view.mean() for view in window_views(path[p] + noise[p], PLAN)]) for p in path}
        elements[name] = [
            {
                "verdict": "ok",
                "gain_mismatch_pct": g,
                "gain_mismatch_pct_interval": (g - Z * ERRORS["gain"], g + Z * ERRORS["gain"]),
                "delay_mismatch_samples": float(np.round(d)),  # the delay's interval: delay_interval's
                "delay_confidence": 0.99,
            }
            for g, d in zip(mean["gain"], mean["delay"], strict=True)
        ]
    return [
        {"first": first, "last": last, "elements": {name: rows[index] for name, rows in elements.items()}}
        for index, (first, last) in enumerate(PLAN)
    ]


@pytest.mark.parametrize("seed", range(3))
def test_a_delay_step_in_integer_estimates_is_a_step_on_its_day_beside_a_gain_drift_and_a_gain_step(seed):
    # windows straddling a +2 step read 0, then 1 (a quarter to three quarters new), then 2: integer stairs over
    # one window that the window means of a step fit (issue 25's year benchmark called them a drift 5 days early)
    from pmr_ros.core.monitor import OnsetSettings

    table = trend_table(_stepping_windows(seed))
    onsets = trend_onsets(table, window=float(WINDOW), time="last", settings=OnsetSettings(scale_errors=True))
    found = onsets.set_index(["element", "parameter"])
    injected = {("G11", "gain"): ("drift", 30), ("G12", "gain"): ("step", 60)}
    injected |= {("G21", "delay"): ("step", 50), ("G22", "delay"): ("step", 75)}
    for key, (kind, day) in injected.items():
        assert found.loc[key, "kind"] == kind, (key, found.loc[key].to_dict())
        # time="last": a window's time is its last day, one day before the instant it ends
        np.testing.assert_allclose(found.loc[key, "onset"] + 1, day, atol=3, err_msg=str(key))
    np.testing.assert_allclose(found.loc[("G21", "delay"), "size"], 2.0, atol=0.3)
    np.testing.assert_allclose(found.loc[("G22", "delay"), "size"], -3.0, atol=0.3)
    still = found.drop(index=list(injected)).drop(index="tau", level="parameter")  # no dtau given: insufficient
    assert set(still["kind"]) == {"none"}, still[still["kind"] != "none"][["kind", "onset", "size"]]
