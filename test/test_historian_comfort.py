"""Historian comfort (issue 24, item 5): every bad string at once, stamp formats and zones, the column count."""

from __future__ import annotations

import pandas as pd
import pytest
from plant_export import DATA_BLOCK, TAGS, clean_frame

from pmr_ros.config import ConfigError, load_config
from pmr_ros.core.sim.closed_loop import simulate
from pmr_ros.data import DataError, load_plant_data

ROWS = 120
DIRT = {"I/O Timeout": 12, "Bad Input": 3, "Comm Fail": 1}
"""What a PI historian writes into a tag that could not be read, and how often, in one column."""


def _config(**data):
    return load_config(overrides={"data": {**DATA_BLOCK, **data}})


@pytest.fixture(scope="module")
def frame():
    config = _config()
    return clean_frame(simulate(config, samples=ROWS))


def _write(tmp_path, frame, name="export.csv"):
    path = tmp_path / name
    frame.to_csv(path, index=False)
    return path


def _steps(data):
    return {step.name: step for step in data.steps}


def test_every_non_numeric_string_of_a_column_is_named_at_once_with_its_count(tmp_path, frame):
    dirty = frame.astype(object)
    row = 10
    for text, count in DIRT.items():
        for _ in range(count):
            dirty.loc[row, TAGS["y"][0]] = text
            row += 3
    dirty.loc[100, TAGS["u"][1]] = "Offline"
    path = _write(tmp_path, dirty)
    with pytest.raises(DataError) as err:
        load_plant_data(path, _config())
    message = str(err.value)
    assert "\n" not in message
    # (data rows count from 1 after the header: frame row 10 is row 11)
    assert message == (
        f"{path}: column '{TAGS['u'][1]}' (data.input_columns[1]): 1 non-numeric string: 'Offline' ×1 (first row "
        f"101); column '{TAGS['y'][0]}' (data.output_columns[0]): 3 non-numeric strings: 'I/O Timeout' ×12 (first "
        "row 11), 'Bad Input' ×3 (first row 47), 'Comm Fail' ×1 (first row 56): not numbers nor data.bad_values (add "
        "them there to read them as missing)"
    )
    # listed as bad values they are read as missing (today's rule), all 17 counted
    data = load_plant_data(path, _config(bad_values=[*DIRT, "Offline", "Bad", ""]))
    bad = _steps(data)["bad values (sentinels, bad strings, empty cells) -> missing"]
    assert bad.count == 17 and f"{TAGS['y'][0]} 16" in bad.detail and f"{TAGS['u'][1]} 1" in bad.detail


def test_a_pi_datalink_stamp_format_reads_with_its_pattern(tmp_path, frame):
    stamps = pd.to_datetime(frame["Timestamp"], format="ISO8601")
    datalink = frame.assign(Timestamp=stamps.dt.strftime("%d-%b-%y %H:%M:%S"))
    assert datalink["Timestamp"].iloc[0] == "01-Mar-24 00:00:00"
    path = _write(tmp_path, datalink)
    with pytest.raises(DataError, match="row 1 = '01-Mar-24 00:00:00': is not an ISO 8601 date-time"):
        load_plant_data(path, _config())
    data = load_plant_data(path, _config(time_format="%d-%b-%y %H:%M:%S"))
    assert data.start == "2024-03-01T00:00:00+00:00" and data.samples == ROWS
    assumed = _steps(data)["time stamps have no zone: taken as UTC"]
    assert assumed.count == ROWS and "data.timezone" in assumed.detail
    datalink.loc[5, "Timestamp"] = "2024-03-01 00:05:00"
    with pytest.raises(DataError, match=r"row 6 = '2024-03-01 00:05:00': does not match data.time_format"):
        load_plant_data(_write(tmp_path, datalink, "mixed.csv"), _config(time_format="%d-%b-%y %H:%M:%S"))


def test_naive_stamps_are_taken_in_the_configured_zone_and_said_so(tmp_path, frame):
    naive = frame.assign(Timestamp=frame["Timestamp"].str.removesuffix("Z"))
    data = load_plant_data(_write(tmp_path, naive), _config(timezone="Europe/Berlin"))
    assert data.start == "2024-02-29T23:00:00+00:00"  # 00:00 in Berlin (CET, UTC+1) is 23:00 UTC
    assert _steps(data)["time stamps have no zone: taken as Europe/Berlin (data.timezone)"].count == ROWS
    zoned = load_plant_data(_write(tmp_path, frame, "zoned.csv"), _config(timezone="Europe/Berlin"))
    assert zoned.start == "2024-03-01T00:00:00+00:00"  # a stamp with its zone keeps it
    assert not [s for s in zoned.steps if "no zone" in s.name]


def test_rows_read_counts_the_used_and_the_ignored_columns(tmp_path, frame):
    wider = frame.assign(**{"TI300.PV": 21.5, "Comment": "shift B"})
    data = load_plant_data(_write(tmp_path, wider), _config())
    step = _steps(data)["rows read"]
    assert (step.count, step.detail) == (ROWS, "10 columns: 8 used, 2 ignored")
    parquet = tmp_path / "export.parquet"
    wider.to_parquet(parquet)
    assert _steps(load_plant_data(parquet, _config()))["rows read"].detail == "10 columns: 8 used, 2 ignored"


@pytest.mark.parametrize(
    ("data", "message"),
    [
        ({"time_format": "dd-mm-yy"}, "data.time_format = 'dd-mm-yy': must be one of detected, iso, seconds or a"),
        ({"timezone": "Mars/Olympus"}, "data.timezone = 'Mars/Olympus': is not a time zone name"),
    ],
)
def test_a_bad_time_setting_is_one_line(data, message):
    with pytest.raises(ConfigError, match=message):
        _config(**data)
