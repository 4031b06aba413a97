"""Data-quality figures (pmr_ros.core.pmr.data_quality): saturation, slow disturbances, and how results carry them."""

from __future__ import annotations

import json
import re
from dataclasses import replace

import numpy as np
import pytest
import rclpy  # noqa: F401  # the ROS 2 wheels are part of the set-up (test.sh)
from rclpy.serialization import serialize_message
from shipped import system_only_params

from pmr_ros.bag.reader import open_bag
from pmr_ros.bag.writer import BagWriter
from pmr_ros.contract.layout import diagnosis_from_array, status_values
from pmr_ros.contract.topics import topic
from pmr_ros.core.pmr.data_quality import (
    RecordQuality,
    assess,
    element_warnings,
    low_frequency_ratio,
    residual_spectra,
    saturation,
)
from pmr_ros.core.pmr.diagnosis import diagnose, diagnose_stretches, with_data_quality
from pmr_ros.core.records import Record
from pmr_ros.core.results import DataQuality, compare_diagnoses
from pmr_ros.core.results.codec import diagnosis_from_json, diagnosis_to_json
from pmr_ros.core.sim.closed_loop import simulate
from pmr_ros.core.sim.true_plant import OutputDisturbance
from pmr_ros.report.table import format_table
from pmr_ros.ros import convert

SAMPLES = 8192


def _stretch(u: np.ndarray) -> Record:
    zeros = np.zeros((u.shape[0], 2))
    return Record(zeros, u, zeros)


# -- saturation ----------------------------------------------------------------------------------


def test_saturation_counts_samples_at_and_beyond_each_limit_over_all_stretches():
    u_min, u_max = np.array([-1.0, 0.0]), np.array([1.0, 10.0])
    first = _stretch(np.array([[1.0, 5.0], [-1.0, 0.0], [0.5, 10.0], [1.0005, 10.02]]))
    second = _stretch(np.array([[-1.5, 5.0], [0.0, 11.0]]))
    at, beyond = saturation([first, second], u_min=u_min, u_max=u_max, tolerance=1e-3)
    # u1: 1, -1 and 1.0005 (within 1e-3 x 2 of the limit) at it, -1.5 beyond; u2: 0 and 10 at, 10.02 and 11 beyond
    np.testing.assert_array_equal(at, [3 / 6, 2 / 6])
    np.testing.assert_array_equal(beyond, [1 / 6, 2 / 6])
    at, _ = saturation([first], u_min=u_min, u_max=u_max, tolerance=0.0)
    np.testing.assert_array_equal(at, [2 / 4, 2 / 4])  # exactly at only
    np.testing.assert_array_equal(saturation([], u_min=u_min, u_max=u_max, tolerance=0.0)[0], [0.0, 0.0])


def test_saturation_share_of_a_tightly_limited_loop_equals_the_samples_the_controller_clipped(wood_berry):
    u_min, u_max = wood_berry.mpc.u_min.copy(), wood_berry.mpc.u_max.copy()
    u_min[0], u_max[0] = -0.45, 0.45
    config = replace(wood_berry, mpc=replace(wood_berry.mpc, u_min=u_min, u_max=u_max))
    record = simulate(config, samples=4096, seed=2)
    # the truth: where the controller put u1 on a limit (the clip returns the limit itself, the QP lands on it
    # within rounding)
    truth = np.mean(np.abs(np.abs(record.u[:, 0]) - 0.45) <= 1e-9)
    at, beyond = saturation([_stretch(record.u)], u_min=u_min, u_max=u_max, tolerance=1e-3)
    assert 0.2 < truth < 0.4 and at[1] == 0.0 and np.all(beyond == 0.0)
    np.testing.assert_allclose(at[0], truth, atol=0.005)  # the tolerance adds the few samples within 0.0009 of it


# -- low-frequency disturbances ------------------------------------------------------------------


def test_low_frequency_ratio_averages_the_lowest_defined_bins_over_the_median():
    residual = np.array([[np.nan, 9.0, 4.0], [8.0, 7.0, 4.0], [1.0, 1.0, 4.0], [1.0, 1.0, 4.0], [1.0, 1.0, 4.0]])
    np.testing.assert_allclose(low_frequency_ratio(residual, bins=2), [4.5, 8.0, 1.0])
    empty = np.full((4, 1), np.nan)
    assert np.isnan(low_frequency_ratio(empty, bins=2)[0])  # a row without regression has no ratio
    assert np.isnan(low_frequency_ratio(np.zeros((4, 1)), bins=1)[0])  # nor a silent one


@pytest.fixture(scope="module")
def disturbed(wood_berry):
    """Wood-Berry, full mismatch, with the issue's output disturbance (std 0.3, pole 0.97) on y1 only."""
    config = replace(wood_berry, disturbance=OutputDisturbance(np.array([0.3, 0.0]), 0.97))
    return config, simulate(config, samples=SAMPLES, seed=3, scenario="full")


def test_residual_spectrum_is_the_disturbance_spectrum_whatever_the_loop_and_the_mismatch(disturbed):
    config, record = disturbed
    omega, residual = residual_spectra(
        [Record(record.r, record.u, record.y)], model=config.model, welch=config.pmr.welch
    )
    # one-sided densities (fs = 1): white noise 2 sigma^2; AR(1) of std s: 2 s^2 (1 - p^2) / |1 - p e^-jw|^2
    p, s, white = 0.97, np.array([0.3, 0.0]), 0.1
    ar = 2 * s**2 * (1 - p**2) / np.abs(1 - p * np.exp(-1j * omega))[:, None] ** 2
    truth = ar + 2 * white**2
    # clear of the window's leakage at the lowest bins, and below 1.2 rad/sample: beyond, the setpoints hardly
    # excite the loop, the per-bin estimate is noisy and its residual up to 3 times the truth (measured)
    band = slice(6, 100)
    ratio = residual[band] / truth[band]
    # 31 Welch segments: a bin's estimate has a standard error of about 20 %, more with the per-bin fit
    assert np.mean((ratio > 0.5) & (ratio < 2.0)) > 0.9
    np.testing.assert_allclose(ratio.mean(axis=0), [1.0, 1.0], rtol=0.15)


def test_assess_finds_the_disturbed_row_and_the_saturated_input(disturbed):
    config, record = disturbed
    # u2's limits at +/- 0.3, "at" within 0.1 x 0.6 of them: as if it had been held near them
    limits = {"u_min": np.array([-2.0, -0.3]), "u_max": np.array([2.0, 0.3]), "limit_tolerance": 0.1}
    settings = replace(config.quality, **limits)
    stretch = Record(record.r, record.u, record.y)
    quality = assess([stretch], model=config.model, welch=config.pmr.welch, settings=settings)
    # the closed form of the disturbed row: the AR(1) + white spectrum's lowest 3 bins over its median, about 380
    omega = np.linspace(0, np.pi, config.pmr.segment_length // 2 + 1)
    truth = 2 * 0.09 * (1 - 0.97**2) / np.abs(1 - 0.97 * np.exp(-1j * omega)) ** 2 + 2 * 0.1**2
    closed = truth[:3].mean() / np.median(truth)
    assert 0.5 < quality.low_frequency[0] / closed < 1.5  # leakage at the lowest bins, per-bin noise in the median
    assert quality.low_frequency[1] < 3  # white noise only: about 1
    size = np.abs(record.u[:, 1])
    assert quality.saturated[0] == quality.outside[0] == 0.0
    assert quality.saturated[1] == np.mean(np.abs(size - 0.3) <= 0.06) and quality.outside[1] == np.mean(size > 0.36)
    assert quality.saturated[1] > 0.05 and quality.outside[1] > 0.05
    assert quality.band == pytest.approx(3 * 2 * np.pi / config.pmr.segment_length)


def test_element_warnings_name_the_input_the_output_the_figure_and_the_threshold(wood_berry):
    quality = RecordQuality(
        saturated=np.array([0.31, 0.02]),
        outside=np.array([0.0, 0.5]),
        low_frequency=np.array([250.0, np.nan]),
        band=0.037,
    )
    settings = wood_berry.quality
    g11 = element_warnings(quality, 0, 0, model=wood_berry.model, settings=settings)
    assert len(g11) == 2
    assert g11[0].startswith("reflux at a limit in 31 % of the samples (> quality.saturation_warn 10 %)")
    assert g11[1].startswith("low-frequency disturbance on x_D: ") and "250 times its median" in g11[1]
    assert "M(0)" in g11[1]
    g22 = element_warnings(quality, 1, 1, model=wood_berry.model, settings=settings)
    assert g22 == (
        "steam beyond mpc.u_min .. mpc.u_max in 50 % of the samples: the configured limits do not "
        "describe the data, saturation is not judged",
    )
    assert (
        element_warnings(quality, 1, 1, model=wood_berry.model, settings=replace(settings, saturation_warn=0.6)) == ()
    )


# -- the result carries them: JSON, /diagnostics, bags ------------------------------------------


@pytest.fixture(scope="module")
def diagnosed(disturbed):
    config, record = disturbed
    return config, diagnose_stretches(
        [Record(record.r, record.u, record.y)],
        model=config.model,
        pmr=config.pmr,
        parametric=config.parametric,
        quality=config.quality,
    )


def test_diagnose_adds_data_quality_without_changing_a_verdict(disturbed, diagnosed):
    config, record = disturbed
    _, diagnosis = diagnosed
    plain = diagnose(record.r, record.u, record.y, model=config.model, pmr=config.pmr, parametric=config.parametric)
    assert all(e.data_quality is None for e in plain)
    for name, e in diagnosis.elements.items():
        assert e.parametric == plain.elements[name].parametric and e.classic == plain.elements[name].classic
        assert e.data_quality is not None and e.data_quality.saturated_share == 0.0
    row1 = [e for e in diagnosis if e.row == 0]
    assert all(len(e.warnings) == 1 and "low-frequency disturbance on x_D" in e.warnings[0] for e in row1)
    assert all(e.warnings == () for e in diagnosis if e.row == 1)
    assert diagnosis.elements["G11"].message().endswith(" [data: 1 warning]")
    assert diagnosis.elements["G21"].message() == diagnosis.elements["G21"].summary()


def test_with_data_quality_sets_each_elements_figures_from_its_input_and_row(diagnosed, wood_berry):
    _, diagnosis = diagnosed
    quality = RecordQuality(np.array([0.5, 0.0]), np.array([0.0, 0.0]), np.array([2.0, np.nan]), 0.037)
    out = with_data_quality(diagnosis, quality, model=wood_berry.model, settings=wood_berry.quality)
    g12, g21 = out.elements["G12"].data_quality, out.elements["G21"].data_quality
    assert g12 == DataQuality(0.0, 0.0, 2.0, ())
    assert g21.saturated_share == 0.5 and g21.low_frequency_ratio is None and "reflux at a limit" in g21.warnings[0]
    assert [e.verdict for e in out] == [e.verdict for e in diagnosis]


def test_data_quality_round_trips_through_json_diagnostics_and_a_bag(tmp_path, diagnosed):
    _, diagnosis = diagnosed
    assert diagnosis_from_json(json.loads(json.dumps(diagnosis_to_json(diagnosis)))) == diagnosis
    window = {"window_samples": diagnosis.samples}
    statuses = convert.diagnosis_statuses(diagnosis, prefix="pmr/wb", hardware_id="wb", window=window)
    assert statuses[0].message.endswith("[data: 1 warning]")
    values = status_values(statuses[0])
    assert values["data_quality.warnings"] == list(diagnosis.elements["G11"].warnings)
    assert values["data_quality.low_frequency_ratio"] == diagnosis.elements["G11"].data_quality.low_frequency_ratio
    msg = convert.diagnostic_array(statuses, 8191.0)
    back, _ = diagnosis_from_array(msg, prefix="pmr/wb")
    assert back == diagnosis  # lossless KeyValues
    name = topic("diagnostics").name
    with BagWriter(tmp_path / "bag", topics={"diagnostics": topic("diagnostics")}) as writer:
        writer.write_raw(name, 1, serialize_message(msg))
    bag = open_bag(tmp_path / "bag")
    recorded, _ = diagnosis_from_array(bag.decode(next(iter(bag.messages({name})))), prefix="pmr/wb")
    assert recorded == diagnosis


def test_a_diagnosis_recorded_without_data_quality_still_agrees_on_everything_it_holds(diagnosed):
    _, diagnosis = diagnosed
    older = replace(diagnosis, elements={n: replace(e, data_quality=None) for n, e in diagnosis.elements.items()})
    assert compare_diagnoses(older, diagnosis) == []
    old_dict = diagnosis_to_json(older)
    for e in old_dict["elements"].values():
        del e["data_quality"]  # a report written before the field existed
    assert compare_diagnoses(old_dict, diagnosis) == []
    g11 = diagnosis.elements["G11"]
    changed = replace(g11, data_quality=replace(g11.data_quality, warnings=()))
    other = replace(diagnosis, elements={**diagnosis.elements, "G11": changed})
    assert compare_diagnoses(other, diagnosis) == ["elements.G11.data_quality.warnings: 0 entries != 1"]


def test_the_verdict_table_lists_the_data_warnings_for_either_method(disturbed, diagnosed):
    from pmr_ros.report import build_report

    config, record = disturbed
    _, diagnosis = diagnosed
    for method in ("parametric", "classic"):
        if method == "classic":
            diagnosis = diagnose_stretches(
                [Record(record.r, record.u, record.y)],
                model=config.model,
                pmr=config.pmr,
                parametric=config.parametric,
                method="classic",
                quality=config.quality,
            )
        table = format_table(diagnosis, build_report(config, diagnosis, command="run", scenario="full", seed=3))
        notes = [line for line in table.splitlines() if "low-frequency disturbance on x_D" in line]
        assert [line.split(":")[0] for line in notes] == ["G11, G12 (2 elements)"], method  # one line per kind


def test_the_html_reports_notes_list_the_data_warnings(diagnosed):
    from pmr_ros.report.html import element_notes

    _, diagnosis = diagnosed
    notes = element_notes(diagnosis.elements["G12"])
    assert notes["warnings"][-1] == diagnosis.elements["G12"].warnings[0]
    assert element_notes(diagnosis.elements["G22"])["warnings"] == list(diagnosis.elements["G22"].parametric.warnings)


# -- plant data: limits only where the params file gives them ------------------------------------

SYSTEM = system_only_params()  # the shipped Wood-Berry system block (config/wood_berry.yaml)


def test_an_export_is_judged_for_saturation_against_the_limits_its_params_file_gives(wood_berry, tmp_path, capsys):
    import pandas as pd

    from pmr_ros.cli import main

    limits = {"u_min": np.array([-0.45, -2.0]), "u_max": np.array([0.45, 2.0])}
    config = replace(wood_berry, mpc=replace(wood_berry.mpc, **limits))
    record = simulate(config, samples=SAMPLES, seed=2)
    frame = pd.DataFrame({"time": np.arange(SAMPLES, dtype=float)})
    for signal, names in (("r", ("x_D", "x_B")), ("u", ("reflux", "steam")), ("y", ("x_D", "x_B"))):
        for j, name in enumerate(names):
            frame[f"{signal}_{name}"] = getattr(record, signal)[:, j]
    frame.to_csv(tmp_path / "export.csv", index=False)
    truth = np.mean(np.abs(np.abs(record.u[:, 0]) - 0.45) <= 1e-9)
    given = SYSTEM + "    mpc:\n      u_min: [-0.45, -2.0]\n      u_max: [0.45, 2.0]\n"
    for name, text in (("none.yaml", SYSTEM), ("limits.yaml", given)):
        (tmp_path / name).write_text(text)
        code = main(["diagnose", str(tmp_path / "export.csv"), "--config", str(tmp_path / name),
                     "--json", str(tmp_path / f"{name}.json")])  # fmt: skip
        out = capsys.readouterr().out
        assert code == 0
        figures = json.loads((tmp_path / f"{name}.json").read_text())["elements"]["G21"]["data_quality"]
        if name == "none.yaml":  # the default limits are the simulation's, not the data's units: not judged
            assert figures["saturated_share"] is None and figures["outside_share"] is None
            assert "reflux at a limit in" not in out and figures["low_frequency_ratio"] < 3
            assert "MV at a limit (flagged, kept)" in out  # the cleaning still flags it at the record's extremes
        else:
            assert figures["saturated_share"] == pytest.approx(truth, abs=0.005) and figures["outside_share"] == 0.0
            assert re.search(r"^G11, G21 \(2 elements\): reflux at a limit in", out, re.M)  # one line for the kind


def test_saturation_is_not_judged_without_known_limits(wood_berry):
    settings = wood_berry.quality.without_limits()
    assert np.all(np.isinf(settings.u_min)) and settings.saturation_warn == wood_berry.quality.saturation_warn
    at, beyond = saturation(
        [_stretch(np.array([[1e9, 0.0], [-1e9, 1.0]]))],
        u_min=np.array([-np.inf, 0.0]),
        u_max=np.array([np.inf, 1.0]),
        tolerance=1e-3,
    )
    assert np.isnan(at[0]) and np.isnan(beyond[0]) and at[1] == 1.0 and beyond[1] == 0.0
    quality = RecordQuality(at, beyond, np.array([1.0, 1.0]), 0.037)
    assert element_warnings(quality, 0, 0, model=wood_berry.model, settings=settings) == ()
