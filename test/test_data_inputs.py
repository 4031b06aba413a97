"""Historian exports a harsh probe sent (issue 21): read right, or refused in one line.

Arrow time units and zones, duplicate columns, gross outliers, year typos,
mode columns, encodings.
"""

from __future__ import annotations

import numpy as np
import pandas as pd
import pyarrow as pa
import pyarrow.parquet as pq
import pytest
from plant_export import DATA_BLOCK, clean_frame

from pmr_ros.config import load_config
from pmr_ros.core.closed_loop import simulate
from pmr_ros.data import DataError, load_plant_data

ROWS = 400


@pytest.fixture(scope="module")
def config():
    return load_config(overrides={"data": DATA_BLOCK})


@pytest.fixture(scope="module")
def frame(config):
    """A clean export of a short closed-loop run: ISO stamps every minute."""
    return clean_frame(simulate(config, samples=ROWS, seed=1))


def _refused(path, config, *words):
    with pytest.raises(DataError) as err:
        load_plant_data(path, config)
    message = str(err.value)
    assert "\n" not in message and str(path) in message
    for word in words:
        assert word in message, message
    return message


def _arrow(frame: pd.DataFrame, unit: str, tz: str | None) -> pa.Table:
    stamps = pd.to_datetime(frame["Timestamp"], utc=True, format="ISO8601")
    table = pa.Table.from_pandas(frame.assign(Timestamp=stamps), preserve_index=False)
    return table.set_column(0, "Timestamp", table.column(0).cast(pa.timestamp(unit, tz=tz)))


@pytest.mark.parametrize("unit", ["s", "ms", "us", "ns"])
@pytest.mark.parametrize("tz", [None, "UTC", "America/Chicago"])
def test_parquet_stamps_in_every_arrow_unit_and_zone_are_read_on_the_grid(tmp_path, config, frame, unit, tz):
    path = tmp_path / "export.parquet"
    pq.write_table(_arrow(frame, unit, tz), path)
    stored = pq.read_schema(path).field("Timestamp").type  # Parquet stores seconds as ms
    assert stored.unit == ("ms" if unit == "s" else unit) and stored.tz == tz
    data = load_plant_data(path, config)
    assert data.start == "2024-03-01T00:00:00+00:00"
    usable = sum(s.samples for s in data.stretches())
    assert usable == ROWS
    np.testing.assert_allclose(data.signals["y"][:, 0], frame["XI101.PV"], rtol=0, atol=1e-12)


def test_parquet_with_a_column_name_twice_is_refused_naming_it(tmp_path, config, frame):
    table = _arrow(frame, "ms", "UTC")
    table = table.append_column("XI101.PV", table.column("XI102.PV"))
    path = tmp_path / "twice.parquet"
    pq.write_table(table, path)
    _refused(path, config, "column 'XI101.PV'", "appears 2 times in the file (columns 6, 9)", "rename")
