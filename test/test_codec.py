"""The result codec (pmr_ros.core.results.codec): every flat form of a diagnosis, both methods, and back.

Round trips of a classic and a parametric diagnosis holding every field (None,
NaN, infinity, inconclusive reasons, an empty cell, impact and data quality)
through JSON, /diagnostics KeyValues, the estimates message and the sweep CSV
row; one spelling of intervals in all of them; the legacy reader on the
reference bag's recorded verdicts and report; the renderers fed the object.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, fields
from pathlib import Path
from types import MappingProxyType

import numpy as np
import pytest

from pmr_ros.bag.reader import open_bag
from pmr_ros.contract.layout import diagnosis_from_array
from pmr_ros.contract.topics import topic
from pmr_ros.core.results import (
    ClassicResult,
    DataQuality,
    Diagnosis,
    ElementDiagnosis,
    ElementModel,
    ImpactResult,
    ParametricResult,
    compare_diagnoses,
)
from pmr_ros.core.results.codec import (
    CSV_FIELDS,
    csv_fields,
    decode_value,
    diagnosis_from_json,
    diagnosis_from_key_values,
    diagnosis_to_json,
    encode_value,
    estimate_fields,
    estimate_names_values,
    estimates_from_names_values,
    result_from_csv_fields,
    status_key_values,
)
from pmr_ros.core.results.plain import part_plain, plain
from pmr_ros.report.table import format_classic_table, format_parametric_table, format_table, summary_line
from pmr_ros.sweep import store

ROOT = Path(__file__).resolve().parents[1]
REFERENCE = ROOT / "bags" / "wood_berry_full"
EXPECTED = ROOT / "bags" / "wood_berry_full.expected.json"
WINDOW = {"window_samples": 4096, "first_sample": 10, "last_sample": 4105}
FOPTD = ElementModel("foptd", 12.8, 16.7, 1)


def _classic_diagnosis() -> Diagnosis:
    """Every classic field: a mismatch with impact and data quality, an integrating element, an inconclusive one."""
    quality = DataQuality(0.25, 0.0, 3.5, ("u1 at a limit 25 % of the samples",))
    elements = {
        "G11": ElementDiagnosis(
            "G11",
            0,
            0,
            FOPTD,
            "classic",
            classic=ClassicResult(1.1234567890123457, 15.9, 2, True, True, True),
            impact=ImpactResult(1.75, 0.5, 1),
            data_quality=quality,
        ),
        "G12": ElementDiagnosis(
            "G12",
            0,
            1,
            ElementModel("integrating", 0.05, None, 3),
            "classic",
            classic=ClassicResult(0.98, None, 0, False, False, False),
            data_quality=DataQuality(None, None, None),
        ),
        "G21": ElementDiagnosis(
            "G21",
            1,
            0,
            FOPTD,
            "classic",
            classic=ClassicResult(1.5, -40.0, 10, True, True, True, reasons=("delay at the search limit",)),
        ),
        "G22": ElementDiagnosis("G22", 1, 1, FOPTD, "classic", reasons=("coherence below 0.5",)),
    }
    return Diagnosis("classic", "ok", "", 8192, elements, impact=ImpactResult(math.inf, 2.5))


def _parametric_diagnosis() -> Diagnosis:
    """Every parametric field: intervals, verdicts, None and NaN numbers, an empty cell, reasons and warnings."""
    fit = ParametricResult(
        gain_mismatch_pct=15.25,
        gain_mismatch_pct_interval=(12.5, 18.0),
        tau_mismatch_pct=-3.0,
        tau_mismatch_pct_interval=(-9.5, 3.5),
        delay_mismatch_samples=1,
        delay_confidence=0.999,
        gain_verdict="mismatch",
        tau_verdict="inconclusive",
        delay_verdict="mismatch",
        reasons=("τ interval wider than ±15 pp",),
        warnings=("coherence low above 0.3 rad/sample",),
        quality={"coherence": 0.81, "condition": math.nan, "segment_length": 512},
    )
    interaction = ParametricResult(
        delay_confidence=0.97,
        gain_verdict=None,
        tau_verdict=None,
        delay_verdict=None,
        unmodeled_gain=0.42,
        unmodeled_gain_interval=(0.4, 0.44),
        unmodeled_delay_samples=3,
        unmodeled_verdict="mismatch",
    )
    classic = ClassicResult(1.16, 20.0, 1, True, True, True)
    elements = {
        "G11": ElementDiagnosis(
            "G11", 0, 0, FOPTD, "parametric", classic=classic, parametric=fit, impact=ImpactResult(1.2, 1.1, 2)
        ),
        "G12": ElementDiagnosis("G12", 0, 1, ElementModel("none", 0.0, None, 0), "parametric", parametric=interaction),
        "G21": ElementDiagnosis(
            "G21", 1, 0, FOPTD, "parametric", classic=classic, parametric=ParametricResult(reasons=("no fit",))
        ),
        "G22": ElementDiagnosis("G22", 1, 1, FOPTD, "parametric", reasons=("too few samples",)),
    }
    return Diagnosis("parametric", "ok", "", 16384, elements, impact=ImpactResult(1.4, 1.2))


DIAGNOSES = {"classic": _classic_diagnosis, "parametric": _parametric_diagnosis}


def _paths(tree: dict, prefix: str = "") -> set[str]:
    out: set[str] = set()
    for key, value in tree.items():
        out |= _paths(value, f"{prefix}{key}.") if isinstance(value, dict) else {f"{prefix}{key}"}
    return out


def _assert_same(back: Diagnosis, diagnosis: Diagnosis) -> None:
    """Equal in everything, NaN equal to NaN (dataclass equality would call NaN != NaN a difference)."""
    assert compare_diagnoses(back, diagnosis) == []
    assert [e.verdict for e in back] == [e.verdict for e in diagnosis]
    assert [e.all_reasons for e in back] == [e.all_reasons for e in diagnosis]


@pytest.mark.parametrize("method", DIAGNOSES)
def test_json_round_trip_through_text(method):
    diagnosis = DIAGNOSES[method]()
    back = diagnosis_from_json(json.loads(json.dumps(diagnosis_to_json(diagnosis))))
    _assert_same(back, diagnosis)
    assert back.impact == diagnosis.impact and back.elements["G11"].impact == diagnosis.elements["G11"].impact
    assert back.elements["G11"].data_quality == diagnosis.elements["G11"].data_quality
    assert diagnosis_from_json(diagnosis_to_json(diagnosis)).elements["G12"] == diagnosis.elements["G12"]


@pytest.mark.parametrize("method", DIAGNOSES)
def test_key_values_round_trip(method):
    diagnosis = DIAGNOSES[method]()
    window = {**WINDOW, "window_samples": diagnosis.samples}  # the wire carries the samples as the window's
    statuses = {e.name: status_key_values(diagnosis, e, state="ok", window=window) for e in diagnosis}
    assert all(isinstance(v, str) for pairs in statuses.values() for _, v in pairs)
    back, common = diagnosis_from_key_values(statuses)
    _assert_same(back, diagnosis)
    assert common == {"status": "ok", "reason": "", **window}
    assert back.impact == diagnosis.impact  # the diagnosis-wide impact_all.* (an unstable loop's inf too)


def test_key_values_of_a_stale_diagnosis_keep_the_word_and_reason():
    models = {"G11": (0, 0, FOPTD)}
    empty = Diagnosis.insufficient(method="parametric", models=models, reason="u stopped", samples=0)
    pairs = {"G11": status_key_values(empty, empty.elements["G11"], state="stale", window={})}
    back, common = diagnosis_from_key_values(pairs)
    assert back.status == "insufficient_data" and common["status"] == "stale" and back.reason == "u stopped"
    assert back.elements["G11"].reasons == ("u stopped",) and back.elements["G11"].result is None


@pytest.mark.parametrize("method", DIAGNOSES)
def test_one_spelling_in_every_form(method):
    """Intervals are ..._low/_high in JSON, KeyValues, estimates and CSV; gain_ratio is always the classic M(0)."""
    diagnosis = DIAGNOSES[method]()
    element = diagnosis.elements["G11"]
    json_paths = _paths(diagnosis_to_json(diagnosis)["elements"]["G11"]) - {"summary"}
    kv_keys = {key for key, _ in status_key_values(diagnosis, element, state="ok", window=WINDOW)}
    assert kv_keys == json_paths | {"status", "reason", *WINDOW, "impact_all.ise_ratio"} | {
        "impact_all.input_movement_ratio",
        "impact_all.rank",
    }
    estimate_names = set(estimate_fields(element))
    assert estimate_names <= json_paths
    csv_names = {name for name, value in csv_fields(element).items() if value is not None}
    assert {f"{method}.{name}" for name in csv_names - {"verdict"}} <= json_paths
    everything = json_paths | kv_keys | estimate_names | csv_names
    assert not [name for name in everything if "_interval" in name]
    # gain_ratio is the classic M(0) = K/Khat wherever it appears
    assert {name for name in everything if "gain_ratio" in name} <= {"classic.gain_ratio", "gain_ratio"}
    if method == "parametric":
        assert {"parametric.gain_mismatch_pct_low", "parametric.gain_mismatch_pct_high"} <= json_paths
        assert csv_fields(element)["gain_ratio"] is None  # the fitted change is gain_mismatch_pct, by that name


@pytest.mark.parametrize("method", DIAGNOSES)
def test_estimates_round_trip(method):
    diagnosis = DIAGNOSES[method]()
    names, values = estimate_names_values(diagnosis)
    back = estimates_from_names_values(names, values)
    assert list(back) == list(diagnosis.elements)
    for element in diagnosis:
        numbers = back[element.name]
        assert list(numbers) == list(estimate_fields(element))
        np.testing.assert_equal(list(numbers.values()), list(estimate_fields(element).values()))
        c = element.classic
        expected = math.nan if c is None else c.gain_ratio
        np.testing.assert_equal(numbers["classic.gain_ratio"], expected)
        p = element.parametric
        if method == "parametric" and p is not None and p.gain_mismatch_pct_interval is not None:
            low, high = p.gain_mismatch_pct_interval
            assert (numbers["parametric.gain_mismatch_pct_low"], numbers["parametric.gain_mismatch_pct_high"]) == (
                low,
                high,
            )
    # an earlier recording's ..._interval.low reads as ..._low
    earlier = estimates_from_names_values(["G11/parametric.gain_mismatch_pct_interval.low"], [1.5])
    assert earlier == {"G11": {"parametric.gain_mismatch_pct_low": 1.5}}


@pytest.mark.parametrize("method", DIAGNOSES)
def test_csv_row_round_trip_through_the_sweep_store(method, tmp_path):
    diagnosis = DIAGNOSES[method]()
    common = {"method": method, "sweep": "tau_G11", "nu": 1.0, "scenario": "full", "seed": 1, "status": "ok"}
    rows = [{**common, "element": e.name, **csv_fields(e)} for e in diagnosis]
    path = tmp_path / store.RESULTS_FILE
    store.append_rows(path, rows)
    back = store.read_rows(path)
    assert [row["verdict"] for row in back] == [e.verdict for e in diagnosis]
    for row, element in zip(back, diagnosis, strict=True):
        result, original = result_from_csv_fields(row, method), element.result
        if original is None or all(row[key] is None for key in CSV_FIELDS if key != "verdict"):
            assert result is None or result.verdict == original.verdict, element.name
            continue
        carried = [f.name for f in fields(original) if f.name not in ("reasons", "warnings", "quality")]
        carried = [name for name in carried if not name.startswith("unmodeled")]
        assert {n: getattr(result, n) for n in carried} == {n: getattr(original, n) for n in carried}, element.name


def test_the_earlier_spelling_of_intervals_still_decodes():
    """A report written before the codec (intervals as [low, high] lists) reads back the same."""
    diagnosis = _parametric_diagnosis()
    earlier = diagnosis_to_json(diagnosis)
    for element in earlier["elements"].values():
        part = element["parametric"]
        if part is None:
            continue
        for base in ("gain_mismatch_pct", "tau_mismatch_pct", "unmodeled_gain"):
            low, high = part.pop(f"{base}_low"), part.pop(f"{base}_high")
            part[f"{base}_interval"] = None if low is None else [low, high]
    _assert_same(diagnosis_from_json(earlier), diagnosis)


def test_values_encode_losslessly():
    for value in (0.1 + 0.2, math.inf, None, True, 3, ["a | b"], np.float64(1.0) / 3):
        back = decode_value(encode_value(value))
        assert back == (value.item() if hasattr(value, "item") else value)
    assert decode_value("not json") == "not json" and encode_value("text") == "text"
    assert math.isnan(decode_value(encode_value(math.nan)))


def _types(value):
    """The value's shape with every leaf's type: plain values compare equal to numpy ones, their types do not."""
    if isinstance(value, dict):
        return {key: (type(key), _types(v)) for key, v in value.items()}
    if isinstance(value, list):
        return [_types(v) for v in value]
    return type(value)


def test_plain_values_are_python_values_in_fresh_containers():
    shares = {"dither_u1": 0.75, "setpoint_y1": 0.25}
    value = {
        "shares": shares,
        "numbers": {1: np.float64(0.5), "n": np.int64(3)},
        "view": MappingProxyType({"flag": np.bool_(True), "texts": ("a", "b")}),
        "pairs": (np.float32(1.5), (None, 2), [True]),
        "empty": (),
    }
    spelt = plain(value)
    assert spelt == {
        "shares": {"dither_u1": 0.75, "setpoint_y1": 0.25},
        "numbers": {"1": 0.5, "n": 3},
        "view": {"flag": True, "texts": ["a", "b"]},
        "pairs": [1.5, [None, 2], [True]],
        "empty": [],
    }
    assert _types(spelt) == _types(json.loads(json.dumps(spelt)))  # what JSON gives back: no numpy type left
    assert spelt["shares"] is not shares  # a copy: the caller may change it


def test_part_plain_spells_each_field_in_order_with_interval_bounds():
    part = ParametricResult(
        gain_mismatch_pct=np.float64(12.0),
        gain_mismatch_pct_interval=(np.float64(9.0), 15.0),
        delay_mismatch_samples=np.int64(2),
        gain_verdict="mismatch",
        reasons=("few samples",),
        quality={"coherence": np.float64(0.9), "bins": 40},
    )
    spelt = part_plain(part)
    keys = []
    for f in fields(ParametricResult):  # the order of the fields, each interval as its two bounds
        base = f.name.removesuffix("_interval")
        keys += [f"{base}_low", f"{base}_high"] if base != f.name else [f.name]
    assert list(spelt) == [*keys, "verdict"]
    assert spelt["gain_mismatch_pct_low"] == 9.0 and spelt["gain_mismatch_pct_high"] == 15.0
    assert spelt["tau_mismatch_pct_low"] is None and spelt["tau_mismatch_pct_high"] is None
    assert (spelt["verdict"], spelt["reasons"], spelt["quality"]) == (
        "mismatch",
        ["few samples"],
        {"coherence": 0.9, "bins": 40},
    )
    assert _types(spelt) == _types(json.loads(json.dumps(spelt)))
    assert list(part_plain(FOPTD)) == ["kind", "gain", "time_constant", "delay_samples"]  # a model: no verdict
    assert part_plain(part) == spelt and part_plain(part)["quality"] is not spelt["quality"]
    assert part_plain(_OneField(np.float64(0.5))) == {"ratio": 0.5}  # one field: its value alone, not a tuple


@dataclass(frozen=True)
class _OneField:
    ratio: float


# -- the reference bag, recorded by pmr_ros 0.1 (flat KeyValues, flat report)


@pytest.fixture(scope="module")
def recorded() -> Diagnosis:
    bag = open_bag(REFERENCE)
    (message,) = list(bag.messages({topic("diagnostics").resolved()}))
    diagnosis, info = diagnosis_from_array(bag.decode(message), "pmr_diagnostician")
    assert info["status"] == "ok" and info["window_samples"] == 8192
    return diagnosis


def test_legacy_statuses_of_the_reference_bag_decode_to_its_report(recorded):
    expected = json.loads(EXPECTED.read_text())
    report = diagnosis_from_json(expected)  # the 0.1 report: flat elements, no model, no name
    assert recorded.method == report.method == "classic" and recorded.samples == report.samples == 8192
    for name, element in recorded.elements.items():
        assert (element.row, element.column) == (int(name[1]) - 1, int(name[2]) - 1)
        assert element.verdict == report.elements[name].verdict == expected["elements"][name]["verdict"]
        assert element.classic == report.elements[name].classic
        assert element.summary() == expected["elements"][name]["summary"]
    assert compare_diagnoses(recorded, report) == []
    # and the recorded verdicts match the injected mismatch: every element of the full scenario is off
    assert all(e.verdict == "mismatch" and "gain" in e.mismatches for e in recorded)
    assert [e.classic.delay_mismatch_samples for e in recorded] == [
        expected["injected"][name]["delay_samples"] for name in recorded.elements
    ]


# -- the renderers read the object


def _heading(**extra) -> dict:
    return {"system": "wood_berry", "command": "run", "scenario": "full", "seed": 1, **extra}


def test_the_table_renders_the_object_of_either_method():
    classic = _classic_diagnosis()
    table = format_table(classic, _heading())
    assert table.startswith("wood_berry: run (classic PMR), scenario full, seed 1, 8192 samples\n")
    g11 = next(line for line in table.splitlines() if line.startswith("G11"))
    assert g11.split()[1:4] == ["1.123", "+12.3", "%"] and "+2" in g11.split()
    assert "G21: delay at the search limit" in table and "G22: coherence below 0.5" in table
    assert "G11: u1 at a limit 25 % of the samples" in table
    assert format_classic_table(classic) in table
    parametric = _parametric_diagnosis()
    body = format_parametric_table(parametric, confidence_level=0.9)
    assert "dK % [90 % interval]" in body.splitlines()[0]
    g11 = next(line for line in body.splitlines() if line.startswith("G11"))
    assert g11.split()[1:5] == ["+15.2", "[", "+12.5,", "+18.0]!"] and "x1.20 (#2)" in g11
    assert "G12      no model: K +0.42 [+0.4,+0.44]!" in body and "+3 (97 %)" in body
    assert "G11: coherence low above 0.3 rad/sample" in body and "G22: too few samples" in body
    level = {"settings": {"parametric": {"confidence_level": 0.9}}}
    assert format_table(parametric, _heading(**level)).endswith(body + summary_line(parametric) + "\n")
    empty = Diagnosis.insufficient(method="classic", models={"G11": (0, 0, FOPTD)}, reason="too short", samples=5)
    assert format_table(empty, _heading(source="plant.csv")) == (
        "wood_berry: run (classic PMR), plant.csv, 5 samples\nINSUFFICIENT DATA: too short\n"
    )
