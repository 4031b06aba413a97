"""Plant data in: historian exports read, placed on the grid, cleaned, diagnosed like the clean record."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from plant_export import DATA_BLOCK, TAGS, as_parquet_frame, clean_frame, dirty_frame, pi_loop

from pmr_ros.config import load_config
from pmr_ros.core.pmr.diagnosis import diagnose, diagnose_stretches
from pmr_ros.core.sim.closed_loop import simulate
from pmr_ros.data import DataError, PlantData, load_plant_data, table_format
from pmr_ros.data.clean import at_limit, frozen, mode_on, repeat_runs, runs
from pmr_ros.data.columns import column_map
from pmr_ros.data.timebase import GridSpec, parse_time, place_on_grid

SAMPLES = 16384


@pytest.fixture(scope="module")
def config():
    return load_config(overrides={"data": DATA_BLOCK})


@pytest.fixture(scope="module")
def records(config):
    """The same plant and mismatch under our MPC and under a decentralized PI loop."""
    return {"mpc": simulate(config, samples=SAMPLES, seed=1), "pi": pi_loop(config, SAMPLES, seed=1)}


def _write(frame: pd.DataFrame, tmp_path, kind: str):
    path = tmp_path / f"export.{kind}"
    if kind == "csv":
        frame.to_csv(path, index=False)
    else:
        as_parquet_frame(frame).to_parquet(path)
    return path


def _diagnose(config, stretches):
    return diagnose_stretches(stretches, model=config.model, pmr=config.pmr, parametric=config.parametric)


@pytest.mark.parametrize("kind", ["csv", "parquet"])
@pytest.mark.parametrize("controller", ["mpc", "pi"])
def test_a_dirty_export_gives_the_clean_records_verdicts(config, records, tmp_path, controller, kind):
    record = records[controller]
    clean = diagnose(record.r, record.u, record.y, model=config.model, pmr=config.pmr, parametric=config.parametric)
    frame, _ = dirty_frame(record, seed=3)
    data = load_plant_data(_write(frame, tmp_path, kind), config)
    dirty = _diagnose(config, data.stretches())
    assert dirty.status == "ok" and clean.status == "ok"
    for name, element in clean.elements.items():
        mine, theirs = dirty.elements[name].parametric, element.parametric
        assert mine.verdicts == theirs.verdicts, name
        assert mine.delay_mismatch_samples == theirs.delay_mismatch_samples, name
        for key in ("gain_mismatch_pct", "tau_mismatch_pct"):
            low, high = getattr(mine, f"{key}_interval")
            # the estimates agree within the uncertainty of the smaller (cleaned) data
            np.testing.assert_allclose(getattr(mine, key), getattr(theirs, key), atol=(high - low) / 2, err_msg=name)


def test_every_kind_of_dirt_is_found_and_counted(config, records, tmp_path):
    frame, dirt = dirty_frame(records["mpc"], seed=3)
    data = load_plant_data(_write(frame, tmp_path, "csv"), config)
    steps = {s.name.split(" (")[0].split(" ->")[0]: s for s in data.steps}
    assert steps["rows read"].count == len(frame) == SAMPLES - len(dirt.dropped) + 1
    assert steps["duplicated rows dropped"].count == 1
    assert steps["time gaps"].count == len(dirt.dropped)
    values = frame[[t for tags in TAGS.values() for t in tags]]
    expected_bad = int(values.isin([-9999, -10000, "Bad", ""]).to_numpy().sum())
    assert steps["bad values"].count == expected_bad >= 10
    assert steps["controller off"].count == dirt.controller_off[1] - dirt.controller_off[0]
    assert data.samples == SAMPLES
    usable = data.usable
    for a, b in [*dirt.frozen, dirt.controller_off]:
        assert not usable[a:b].any()
    assert not usable[dirt.dropped].any()
    assert usable.sum() == steps["usable samples"].count >= SAMPLES - 1000


def test_clean_stretches_are_deviation_variables(config, records, tmp_path):
    frame = clean_frame(records["mpc"])
    data = load_plant_data(_write(frame, tmp_path, "csv"), config)
    (stretch,) = data.stretches()
    np.testing.assert_allclose(stretch.u, records["mpc"].u - records["mpc"].u.mean(axis=0), atol=1e-9)
    np.testing.assert_allclose(stretch.y.mean(axis=0), 0.0, atol=1e-9)
    (raw,) = data.stretches(deviations=False)  # as read: where an MV's limits are judged
    np.testing.assert_allclose(raw.u - stretch.u, np.broadcast_to(raw.u.mean(axis=0), raw.u.shape), atol=1e-9)
    assert np.all(np.abs(raw.u.mean(axis=0)) > 1.0)  # the export's operating point (engineering values)


def _equivalent_segments(config, lengths: list[int]) -> float:
    welch = config.parametric.welch(config.model, max(lengths), config.pmr)
    warmup = config.model.settling_samples()
    return sum(welch.equivalent_segments(welch.segments(n - warmup)) for n in lengths)


def test_twelve_gaps_give_the_same_verdicts_and_intervals_within_ten_percent(config):
    """The clean data add up to the gap-free record's length; one estimate from all thirteen stretches.

    Each stretch loses its start-up (the model filter's settling) and the end
    that no Welch segment fits; the intervals widen by the square root of the
    ratio of equivalent segments (sqrt(206 / 182) = 1.064 here) and no more:
    within 10 % of that.
    """
    gap, stretch = 500, 8192
    total = 13 * stretch + 12 * gap
    record = simulate(config, samples=total, seed=2)
    signals = {"r": record.r.copy(), "u": record.u.copy(), "y": record.y.copy()}
    for j in range(12):
        start = (j + 1) * stretch + j * gap
        signals["y"][start : start + gap, j % 2] = np.nan
    gapped = PlantData.from_record(signals, source="gaps", sample_time_s=60.0)
    assert [b - a for a, b in gapped.stretch_bounds()] == [stretch] * 13
    n = 13 * stretch
    plain = {"r": record.r[:n], "u": record.u[:n], "y": record.y[:n]}
    whole = _diagnose(config, PlantData.from_record(plain, source="whole", sample_time_s=60.0).stretches())
    split = _diagnose(config, gapped.stretches())
    widening = np.sqrt(_equivalent_segments(config, [n]) / _equivalent_segments(config, [stretch] * 13))
    assert 1.0 < widening < 1.08
    for name, element in whole.elements.items():
        mine, theirs = split.elements[name].parametric, element.parametric
        assert mine.verdicts == theirs.verdicts, name
        for key in ("gain_mismatch_pct_interval", "tau_mismatch_pct_interval"):
            width, reference = np.diff(getattr(mine, key))[0], np.diff(getattr(theirs, key))[0]
            np.testing.assert_allclose(width / reference, widening, rtol=0.10, err_msg=f"{name} {key}")


# -- bad input: one line naming the file, the column (and row) and the value


def _csv(tmp_path, frame: pd.DataFrame, name: str = "bad.csv"):
    path = tmp_path / name
    frame.to_csv(path, index=False)
    return path


@pytest.fixture()
def small(records):
    record = records["mpc"]
    return clean_frame(type(record)(record.r[:50], record.u[:50], record.y[:50]))


def _refused(path, config, *words):
    with pytest.raises(DataError) as err:
        load_plant_data(path, config)
    message = str(err.value)
    assert "\n" not in message and str(path) in message
    for word in words:
        assert word in message, message
    return message


def test_a_missing_column_is_named_with_the_nearest_one(tmp_path, config, small):
    path = _csv(tmp_path, small.rename(columns={"XI101.PV": "XI101.PV "}))
    _refused(path, config, "column 'XI101.PV' (data.output_columns[0])", "not in the file", "did you mean 'XI101.PV '")


def test_a_column_without_one_valid_value(tmp_path, config, small):
    small["FC202.OP"] = -9999
    _refused(_csv(tmp_path, small), config, "column 'FC202.OP' (data.input_columns[1])", "no valid value", "all 50")


def test_text_that_is_no_number_nor_a_bad_value_is_refused_with_its_row(tmp_path, config, small):
    small = small.astype(object)
    small.loc[7, "XI102.PV"] = "I/O Timeout"
    _refused(_csv(tmp_path, small), config, "column 'XI102.PV'", "row 8", "'I/O Timeout'", "data.bad_values")


def test_files_that_are_not_csv_or_parquet(tmp_path, config, small):
    _refused(tmp_path / "export.xlsx", config, "not a CSV or Parquet file", ".xlsx")
    fake = tmp_path / "export.parquet"
    small.to_csv(fake, index=False)
    _refused(fake, config, "not a Parquet file")
    binary = tmp_path / "binary.csv"
    binary.write_bytes(b"PK\x03\x04\x00\x00binary")
    _refused(binary, config, "binary data")
    _refused(tmp_path / "absent.csv", config, "no such file")


def test_a_time_column_that_does_not_parse(tmp_path, config, small):
    small = small.astype(object)
    small.loc[3, "Timestamp"] = "yesterday noon"
    _refused(_csv(tmp_path, small), config, "column 'Timestamp' (data.time_column), row 4", "'yesterday noon'", "ISO")


def test_stamps_off_the_grid_back_in_time_or_duplicated_are_refused_with_the_row(tmp_path, config, small):
    stamps = pd.to_datetime(small["Timestamp"], format="ISO8601")
    off = small.copy()
    off.loc[10, "Timestamp"] = (stamps[10] + pd.Timedelta(seconds=25)).isoformat()
    _refused(_csv(tmp_path, off), config, "row 11", "+0.42 samples off the 60 s sample grid")
    back = small.copy()
    back.loc[20, "Timestamp"] = small.loc[5, "Timestamp"]
    _refused(_csv(tmp_path, back), config, "row 21", "goes back in time")
    twice = small.copy()
    twice.loc[21, "Timestamp"] = small.loc[20, "Timestamp"]
    _refused(_csv(tmp_path, twice), config, "row 22", "same sample as row 21", "UTC")


def test_a_model_in_minutes_without_the_time_unit_is_told_how_to_fix_it(tmp_path, small):
    config = load_config(overrides={"data": {**DATA_BLOCK, "time_unit_s": 1.0}})
    _refused(_csv(tmp_path, small), config, "60 s apart", "data.time_unit_s", "60 for minutes")


# -- the pieces


def test_runs_and_repeat_runs():
    assert runs(np.array([0, 1, 1, 0, 1], dtype=bool)) == [(1, 3), (4, 5)]
    assert runs(np.zeros(3, dtype=bool)) == []
    assert repeat_runs(np.array([1.0, 2.0, 2.0, 2.0, np.nan, np.nan, 3.0, 3.0])) == [(1, 4), (6, 8)]


def test_frozen_only_on_a_normally_noisy_tag_and_not_at_a_limit():
    noisy = np.random.default_rng(0).normal(size=300)
    noisy[100:130] = noisy[100]
    assert np.flatnonzero(frozen(noisy, 20)).tolist() == list(range(100, 130))
    assert not frozen(noisy, 30).any() and not frozen(noisy, 0).any()
    held = np.repeat(np.arange(10.0), 30)  # a setpoint: constant by nature
    assert not frozen(held, 20).any()
    keep = np.zeros(300, dtype=bool)
    keep[110:130] = True
    assert np.flatnonzero(frozen(noisy, 20, keep=keep)).tolist() == list(range(100, 110))


def test_an_input_held_at_its_extreme_is_at_a_limit():
    u = np.array([0.0, 0.5, 2.0, 2.0, 2.0, 1.0, -1.0, -1.0, 0.3, 2.0])
    assert np.flatnonzero(at_limit(u)).tolist() == [2, 3, 4, 6, 7]
    assert not at_limit(np.full(3, np.nan)).any()


def test_mode_on_compares_numbers_as_numbers_and_text_stripped_regardless_of_case():
    mode = np.array([1, 1.0, "1", " AUTO ", "MAN", None, 0, "auto", True, False, np.True_], dtype=object)
    on = [True, True, True, True, False, False, False, True, True, False, True]
    assert mode_on(mode, (1.0, "AUTO")).tolist() == on


def test_column_map_default_naming_and_data_block(config):
    default = column_map(load_config().data, config.model)
    assert default.signals == {"r": ("r_x_D", "r_x_B"), "u": ("u_reflux", "u_steam"), "y": ("y_x_D", "y_x_B")}
    assert default.all[0] == "time" and default.mode == ""
    mapped = column_map(config.data, config.model)
    assert mapped.signals["u"] == TAGS["u"] and mapped.all[-1] == "XC_MODE"
    assert mapped.origin("FC202.OP") == "data.input_columns[1]"


def test_table_format_by_suffix():
    assert table_format("a/b.CSV") == "csv" and table_format("x.parquet") == "parquet" and table_format("x.pq")
    assert table_format("bag_dir") is None and table_format("x.mcap") is None


def test_parse_time_iso_with_offsets_and_seconds():
    iso = parse_time(pd.Series(["2024-03-31T00:59:00+00:00", "2024-03-31T03:00:00+02:00"]), "detected", path="f",
                     column="t")  # fmt: skip
    np.testing.assert_allclose(iso.seconds, [0.0, 60.0])
    assert iso.iso and iso.start.startswith("2024-03-31T00:59:00")
    numbers = parse_time(pd.Series([120.0, 180.0]), "detected", path="f", column="t")
    np.testing.assert_allclose(numbers.seconds, [0.0, 60.0])
    with pytest.raises(DataError, match="row 2.*not a number of seconds"):
        parse_time(pd.Series(["1", "x"]), "seconds", path="f", column="t")


def test_place_on_grid_moves_jitter_and_counts_gaps():
    seconds = np.array([0.0, 61.0, 119.0, 240.0, 299.5])
    grid = place_on_grid(seconds, np.arange(5.0)[:, None], GridSpec(60.0, 0.25, "f", "t"))
    assert grid.index.tolist() == [0, 1, 2, 4, 5] and grid.samples == 6 and grid.gaps == 1
    assert grid.moved == 3 and grid.largest_offset == pytest.approx(1 / 60, abs=1e-3)


def test_from_record_is_all_usable_unless_a_value_is_missing():
    signals = {"r": np.zeros((5, 1)), "u": np.ones((5, 2)), "y": np.zeros((5, 1))}
    signals["y"][2, 0] = np.nan
    data = PlantData.from_record(signals, source="bag", sample_time_s=1.0)
    assert data.stretch_bounds() == [(0, 2), (3, 5)] and data.time_s.tolist() == [0.0, 1.0, 2.0, 3.0, 4.0]
