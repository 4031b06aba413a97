"""Historian data of routine operation: measured disturbances, per-MV controller modes, zone CVs without setpoints.

A record with DVs and manual stretches, exported as the historian would (DV
columns, no setpoint column for a zone CV, a mode tag per MV) and read back,
is the same record: r, u, y, dv and manual.
"""

from __future__ import annotations

import copy
from dataclasses import replace

import numpy as np
import pandas as pd
import pytest
import yaml
from plant_export import ExportTags, export_frame, export_tags

from pmr_ros.config import ConfigError, load_config
from pmr_ros.config.data import check_data_settings, disturbance_names, output_modes
from pmr_ros.core.records import Record
from pmr_ros.data import DataError, load_plant_data
from pmr_ros.data.clean import mode_known, mode_on
from pmr_ros.data.columns import column_map
from pmr_ros.service.historian import diagnose_table
from pmr_ros.service.refusal import ServiceError

N = 900
MODES = ("setpoint", "zone", "setpoint")
DVS = ("feed_rate", "feed_comp")
TAGS = ExportTags(
    r=("AC1.SP", "", "TC3.SP"),
    u=("FC1.OP", "FC2.OP"),
    y=("AC1.PV", "PC2.PV", "TC3.PV"),
    dv=("FI9.PV", "AI9.PV"),
    modes=("FC1.MODE", "FC2.MODE"),
)
NOMINAL = {
    "r": np.array([95.0, 0.0, 80.0]),
    "u": np.array([2.0, 1.5]),
    "y": np.array([95.0, 12.0, 80.0]),
    "dv": np.array([40.0, 0.45]),
}
MANUAL_U1 = (100, 250)
"""MV 1's controller off (kept, open loop for it)."""
MANUAL_U2 = (500, 560)
ALL_OFF = (600, 640)
"""Both controllers off: excluded, the record splits there."""
SYSTEM = {
    "sample_time": 1.0,
    "output_names": ["x_top", "p_top", "t_tray"],
    "input_names": ["reflux", "steam"],
    "gain": [1.0, -0.5, 0.3, 0.8, -0.2, 1.1],
    "time_constant": [10.0, 12.0, 8.0, 9.0, 15.0, 11.0],
    "delay": [1.0, 2.0, 0.0, 1.0, 3.0, 1.0],
}


def _record(seed: int = 5, *, operator: bool = True) -> Record:
    """Closed-loop-looking data: setpoint steps, noisy u and y, DVs as random steps, operator moves in manual."""
    rng = np.random.default_rng(seed)
    r = np.zeros((N, 3))
    r[:, 0] = np.repeat(rng.normal(0.0, 1.0, N // 150), 150)
    r[:, 2] = np.repeat(rng.normal(0.0, 2.0, N // 300), 300)  # r[:, 1]: the zone CV's, constant
    u = np.cumsum(rng.normal(0.0, 0.01, (N, 2)), axis=0) + rng.normal(0.0, 0.02, (N, 2))
    y = np.cumsum(rng.normal(0.0, 0.05, (N, 3)), axis=0) + rng.normal(0.0, 0.1, (N, 3))
    dv = np.column_stack([np.repeat(rng.normal(0.0, s, N // 60), 60) for s in (3.0, 0.02)])
    manual = np.zeros((N, 2), dtype=bool)
    for k, (a, b) in enumerate((MANUAL_U1, MANUAL_U2) if operator else ()):
        manual[a:b, k] = True
        u[a:b, k] = np.repeat(u[a, k] + np.array([0.0, 0.3, -0.1]), -(-(b - a) // 3))[: b - a]  # held, stepped
    manual[ALL_OFF[0] : ALL_OFF[1]] = True
    return Record(r, u, y, dv=dv, manual=manual) if operator else Record(r, u, y, dv=dv)


def _config(tmp_path, tags: ExportTags = TAGS, *, dvs=DVS, modes=MODES, **data):
    """The config of the export; DV names and output modes laid into its tree as the system and mpc blocks give them."""
    block = {key: value for key, value in tags.data_block().items() if key != "disturbance_columns"}
    doc = {"/**": {"ros__parameters": {"system": SYSTEM, "data": block | data}}}
    path = tmp_path / "routine.yaml"
    path.write_text(yaml.safe_dump(doc))
    config = load_config(path)
    tree = copy.deepcopy(config.parameters)
    tree["system"]["disturbance_names"] = list(dvs)
    tree.setdefault("mpc", {})["output_mode"] = list(modes)
    return replace(config, parameters=tree, data=replace(config.data, disturbance_columns=tags.dv))


def _write(frame: pd.DataFrame, tmp_path, kind: str):
    path = tmp_path / f"routine.{kind}"
    frame.to_csv(path, index=False) if kind == "csv" else frame.to_parquet(path, index=False)
    return path


@pytest.mark.parametrize("kind", ["csv", "parquet"])
def test_simulate_export_read_gives_the_same_record(tmp_path, kind):
    record = _record()
    config = _config(tmp_path)
    frame = export_frame(record, TAGS, nominal=NOMINAL)
    assert "AC1.SP" in frame and not any(c.startswith("PC2.SP") for c in frame)  # the zone CV: no setpoint column
    data = load_plant_data(_write(frame, tmp_path, kind), config)
    assert data.stretch_bounds() == [(0, ALL_OFF[0]), (ALL_OFF[1], N)]
    read = data.stretches(deviations=False)
    for (a, b), stretch in zip(data.stretch_bounds(), read, strict=True):
        for signal, tol in (("u", 1e-9), ("y", 1e-9), ("dv", 1e-9)):
            expected = getattr(record, signal)[a:b] + NOMINAL[signal]
            np.testing.assert_allclose(getattr(stretch, signal), expected, rtol=0, atol=tol, err_msg=signal)
        np.testing.assert_allclose(stretch.r[:, [0, 2]], record.r[a:b][:, [0, 2]] + NOMINAL["r"][[0, 2]], atol=1e-9)
        np.testing.assert_allclose(stretch.r[:, 1], 0.0, atol=0)  # no setpoint column: constant, no instrument
        manual = record.manual[a:b]
        assert np.array_equal(stretch.manual, manual) if manual.any() else stretch.manual is None
    deviations = data.stretches()
    np.testing.assert_allclose(deviations[0].dv, record.dv[:600] - record.dv[:600].mean(axis=0), atol=1e-9)
    steps = {s.name.split(" (")[0].split(" ->")[0]: s for s in data.steps}
    assert steps["controller off"].count == ALL_OFF[1] - ALL_OFF[0]
    kept = (MANUAL_U1[1] - MANUAL_U1[0]) + (MANUAL_U2[1] - MANUAL_U2[0])
    assert steps["MV in manual"].count == kept and "FC1.OP 150" in steps["MV in manual"].detail
    assert steps["frozen values"].count == 0  # an MV the operator holds is no frozen tag


def test_a_record_all_on_reads_back_without_manual(tmp_path):
    record = _record(operator=False)
    data = load_plant_data(_write(export_frame(record, TAGS), tmp_path, "csv"), _config(tmp_path))
    (stretch,) = data.stretches(deviations=False)
    assert stretch.manual is None
    np.testing.assert_allclose(stretch.dv, record.dv, atol=1e-9)


def test_bad_dv_cells_are_missing_and_split_the_record(tmp_path):
    frame = export_frame(_record(operator=False), TAGS, nominal=NOMINAL).astype(object)
    frame.loc[300, "FI9.PV"] = -9999
    frame.loc[700, "AI9.PV"] = 1.0e6  # no sentinel: a gross outlier
    data = load_plant_data(_write(frame, tmp_path, "csv"), _config(tmp_path))
    assert data.stretch_bounds() == [(0, 300), (301, 700), (701, N)]
    assert all(np.isfinite(s.dv).all() for s in data.stretches())


def test_a_mode_unknown_excludes_its_sample_and_one_mode_column_still_serves_all(tmp_path):
    record = _record()
    frame = export_frame(record, TAGS)
    frame.loc[50, "FC2.MODE"] = "Bad"
    frame.loc[51, "FC1.MODE"] = ""
    data = load_plant_data(_write(frame, tmp_path, "csv"), _config(tmp_path))
    assert np.flatnonzero(data.excluded["mode unknown"]).tolist() == [50, 51]
    one = ExportTags(TAGS.r, TAGS.u, TAGS.y, TAGS.dv, ("XC.MODE",))
    single = export_frame(_record(operator=False), one)
    single.loc[ALL_OFF[0] : ALL_OFF[1] - 1, "XC.MODE"] = "man"
    config = _config(tmp_path, one, mode_columns=[], mode_column="XC.MODE")
    got = load_plant_data(_write(single, tmp_path, "parquet"), config)
    assert got.stretch_bounds() == [(0, ALL_OFF[0]), (ALL_OFF[1], N)]
    assert got.manual is not None and not got.manual[got.usable].any()


def test_mode_cells_of_every_spelling():
    cells = np.array(["AUTO", "auto ", "MAN", True, False, "true", "False", 1, 0.0, None, np.nan, "Bad"], dtype=object)
    assert mode_on(cells, (1.0, "AUTO")).tolist() == [1, 1, 0, 1, 0, 1, 0, 1, 0, 0, 0, 0]
    assert mode_known(cells, (-9999.0, "Bad", "")).tolist() == [1] * 9 + [0, 0, 0]


# -- bad input: one line each ------------------------------------------------------------------------


def test_a_dv_column_missing_from_the_file_is_named(tmp_path):
    frame = export_frame(_record(), TAGS).drop(columns=["AI9.PV"])
    with pytest.raises(DataError) as err:
        load_plant_data(_write(frame, tmp_path, "csv"), _config(tmp_path))
    line = str(err.value)
    assert "routine.csv" in line and "'AI9.PV' (data.disturbance_columns[1])" in line and "not in the file" in line
    assert "\n" not in line


def test_dvs_declared_without_columns_is_one_line_through_the_service(tmp_path):
    config = _config(tmp_path)
    config = replace(config, data=replace(config.data, disturbance_columns=()))
    path = _write(export_frame(_record(), TAGS), tmp_path, "csv")
    with pytest.raises(ServiceError) as err:
        diagnose_table(path, config)
    line = str(err.value)
    assert "data.disturbance_columns" in line and "feed_rate, feed_comp" in line and "\n" not in line


def test_a_mode_column_list_of_the_wrong_length_is_refused(tmp_path):
    with pytest.raises(ConfigError) as err:
        _config(tmp_path, mode_columns=["A", "B", "C"])
    assert err.value.field == "data.mode_columns" and "needs 1 or 2 column names" in str(err.value)
    assert "got 3" in str(err.value) and "\n" not in str(err.value)


def test_both_mode_spellings_are_refused(tmp_path):
    with pytest.raises(ConfigError, match="not both"):
        _config(tmp_path, mode_column="XC.MODE")


def _check(data_block: dict, tree: dict):
    config = load_config(None)
    data = replace(config.data, **data_block)
    return check_data_settings(data, tree, output_names=("a", "b", "c"), source_of=lambda name: "p.yaml")


def test_a_zone_cv_given_a_setpoint_column_is_a_warning_naming_it():
    tree = {"mpc": {"output_mode": ["setpoint", "zone", "setpoint"]}}
    (warning,) = _check({"setpoint_columns": ("A.SP", "B.SP", "C.SP")}, tree)
    assert warning.startswith("p.yaml: data.setpoint_columns[1] = 'B.SP'") and "b is a zone CV" in warning
    assert _check({"setpoint_columns": ("A.SP", "", "C.SP")}, tree) == ()


@pytest.mark.parametrize(
    ("names", "columns", "words"),
    [(["f", "c"], ("F",), "declares 2 DV(s) (f, c); got 1"), ([], ("F",), "declares no DV; got 1")],
)
def test_dv_columns_must_match_the_declared_dvs(names, columns, words):
    with pytest.raises(ConfigError) as err:
        _check({"disturbance_columns": columns}, {"system": {"disturbance_names": names}})
    assert err.value.field == "data.disturbance_columns" and words in str(err.value)


def test_blank_setpoint_entries_and_the_zone_default(tmp_path):
    config = _config(tmp_path, setpoint_columns=["A", None, ""])
    assert config.data.setpoint_columns == ("A", "", "")
    default = replace(config.data, setpoint_columns=())
    columns = column_map(default, config.model, output_modes=MODES)
    assert columns.signals["r"] == ("r_x_top", "", "r_t_tray") and "" not in columns.all
    with pytest.raises(ConfigError, match="column names"):
        _config(tmp_path, input_columns=["A", ""])


def test_the_tree_readers_are_defensive():
    assert disturbance_names({}) == () and disturbance_names({"system": {"disturbance_names": ["f"]}}) == ("f",)
    assert output_modes({}, 2) == ("setpoint", "setpoint")
    assert output_modes({"mpc": {"output_mode": "zone"}}, 2) == ("zone", "zone")
    assert output_modes({"mpc": {"output_mode": ["zone", "setpoint"]}}, 2) == ("zone", "setpoint")


def test_the_tags_of_a_simulated_run_read_back_with_their_data_block(tmp_path):
    config = _config(tmp_path)
    tags = export_tags(config)
    assert tags.r == ("r_x_top", "", "r_t_tray") and tags.dv == ("d_feed_rate", "d_feed_comp")
    block = tags.data_block()
    data = replace(config.data, setpoint_columns=tuple(block["setpoint_columns"]), disturbance_columns=tags.dv)
    data = replace(data, input_columns=tags.u, output_columns=tags.y, mode_columns=tags.modes)
    record = _record()
    got = load_plant_data(_write(export_frame(record, tags), tmp_path, "csv"), replace(config, data=data))
    (first, _) = got.stretches(deviations=False)
    np.testing.assert_allclose(first.dv, record.dv[: ALL_OFF[0]], atol=1e-9)
    assert np.array_equal(first.manual, record.manual[: ALL_OFF[0]])
