"""Bags without ROS: writing/reading with rosbags, the reference bag, an independent MCAP reader, bad input.

The reference bag ``bags/wood_berry_full`` was recorded by a real
``pmr-ros run --bag`` (see bags/README.md); its expected verdicts beside it
are that run's report.
"""

from __future__ import annotations

import json
import shutil
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
import yaml

from pmr_ros.bag.offline import bag_configuration, required_topics
from pmr_ros.bag.reader import open_bag
from pmr_ros.bag.storage import (
    CUSTOM_DATA_KEYS,
    RUN_CONFIG_KEY,
    BagError,
    RunConfig,
    recorded_topics,
    rosbags_qos,
    typestore,
)
from pmr_ros.bag.writer import BagWriter, looks_like_bag, prepare_output
from pmr_ros.cli import main
from pmr_ros.config import load_config
from pmr_ros.contract.alignment import SampleAligner
from pmr_ros.contract.layout import diagnosis_from_array, level_name, read_estimates, read_signal
from pmr_ros.contract.topics import topic
from pmr_ros.contract.windowing import INSUFFICIENT, STALE, VERDICT, evaluate_window, offer_signal, window_info
from pmr_ros.core.results import compare_diagnoses
from pmr_ros.core.results.codec import diagnosis_to_json
from pmr_ros.service.bag_diagnosis import compare, diagnose_bag

ROOT = Path(__file__).resolve().parents[1]
REFERENCE = ROOT / "bags" / "wood_berry_full"
EXPECTED = ROOT / "bags" / "wood_berry_full.expected.json"


def _time(seconds: float):
    ns = int(round(seconds * 1e9))
    return typestore().types["builtin_interfaces/msg/Time"](sec=ns // 10**9, nanosec=ns % 10**9)


def _joint_state(k: int, values, names):
    ts = typestore().types
    header = ts["std_msgs/msg/Header"](stamp=_time(float(k)), frame_id="wood_berry")
    return ts["sensor_msgs/msg/JointState"](
        header=header,
        name=list(names),
        position=np.asarray(values, dtype=float),
        velocity=np.zeros(0),
        effort=np.zeros(0),
    )


def _write_small_bag(
    path: Path,
    samples: int = 50,
    storage: str = "mcap",
    skip: tuple[str, ...] = (),
    config: RunConfig | None = None,
    **kwargs,
) -> BagWriter:
    """A bag of ``samples`` samples of r, u, y and /clock (values from the batch core's Wood-Berry run)."""
    topics = {k: t for k, t in recorded_topics().items() if k not in skip}
    writer = BagWriter(path, storage=storage, topics=topics, **kwargs)
    if config is not None:
        writer.write_run_config(config, 1)
    ts = typestore().types
    rng = np.random.default_rng(0)
    for k in range(samples):
        t = 10 + k * 1000
        if "clock" in topics:
            writer.write_message(topic("clock").resolved(), t, ts["rosgraph_msgs/msg/Clock"](clock=_time(float(k))))
        for key, names in (
            ("measured_output", ("x_D", "x_B")),
            ("setpoint", ("x_D", "x_B")),
            ("manipulated_input", ("reflux", "steam")),
        ):
            if key in topics:
                writer.write_message(topic(key).resolved(), t + 1, _joint_state(k, rng.normal(size=2), names))
    return writer


@pytest.fixture(scope="module")
def expected():
    return json.loads(EXPECTED.read_text())


@pytest.fixture(scope="module")
def reference_result():
    bag = open_bag(REFERENCE)
    return bag, diagnose_bag(bag)


# -- schema and writer -------------------------------------------------------------------------


def test_run_config_round_trips_through_topic_text_and_custom_data(wood_berry):
    config = RunConfig(wood_berry.parameters, source="config/wood_berry.yaml")
    back = RunConfig.from_text(config.to_text())
    assert back.params == wood_berry.parameters and back.source == "config/wood_berry.yaml"
    custom = config.custom_data()
    assert set(custom) == set(CUSTOM_DATA_KEYS) and all(isinstance(v, str) for v in custom.values())
    assert custom["pmr_ros.seed"] == str(wood_berry.run.seed) and custom["pmr_ros.scenario"] == wood_berry.run.scenario
    assert RunConfig.from_custom_data(custom).params == wood_berry.parameters
    assert RunConfig.from_custom_data({}) is None
    assert yaml.safe_load(config.params_yaml())["/**"]["ros__parameters"] == wood_berry.parameters
    with pytest.raises(BagError, match="not a pmr_ros params document"):
        RunConfig.from_text("just a string")


def test_recorded_topics_are_the_contract_with_its_qos():
    topics = recorded_topics()
    assert {
        "setpoint",
        "measured_output",
        "manipulated_input",
        "clock",
        "diagnostics",
        "estimates",
        RUN_CONFIG_KEY,
    } <= set(topics)
    qos = rosbags_qos(topics["setpoint"].qos)
    assert qos.depth == 1000 and qos.reliability.name == "RELIABLE" and qos.durability.name == "TRANSIENT_LOCAL"


@pytest.mark.parametrize("storage", ["mcap", "sqlite3"])
def test_writer_and_reader_round_trip_every_message(tmp_path, wood_berry, storage):
    config = RunConfig(wood_berry.parameters, source="test")
    writer = _write_small_bag(tmp_path / "bag", 40, storage, config=config)
    assert writer.flushes >= 1  # the configuration is flushed at once
    writer.close()
    bag = open_bag(tmp_path / "bag")
    assert bag.complete and bag.storage == storage
    assert bag.counts[topic("setpoint").resolved()] == 40 and bag.counts[topic("clock").resolved()] == 40
    assert bag.topics[topic("setpoint").resolved()] == "sensor_msgs/msg/JointState"
    assert bag.run_config().params == wood_berry.parameters
    stamps = [read_signal(bag.decode(m))[0] for m in bag.messages({topic("measured_output").resolved()})]
    assert stamps == [float(k) for k in range(40)]


def test_prepare_output_never_overwrites_without_force_and_never_deletes_a_non_bag(tmp_path):
    assert prepare_output(tmp_path / "new", force=False) == tmp_path / "new"
    _write_small_bag(tmp_path / "old", 3).close()
    assert looks_like_bag(tmp_path / "old")
    with pytest.raises(BagError, match="exists already; pass --force"):
        prepare_output(tmp_path / "old", force=False)
    prepare_output(tmp_path / "old", force=True)
    assert not (tmp_path / "old").exists()
    (tmp_path / "docs").mkdir()
    (tmp_path / "docs" / "thesis.tex").write_text("precious")
    with pytest.raises(BagError, match="not a rosbag2 bag; not overwriting"):
        prepare_output(tmp_path / "docs", force=True)
    assert (tmp_path / "docs" / "thesis.tex").exists()
    with pytest.raises(BagError, match="parent folder"):
        prepare_output(tmp_path / "missing" / "bag", force=False)


def test_an_unclosed_bag_is_read_up_to_its_last_flush(tmp_path):
    writer = _write_small_bag(tmp_path / "bag", 30, flush_period_s=3600)  # no automatic flush
    writer.flush()
    flushed = writer.message_count
    ts = typestore().types
    for k in range(30, 40):  # written after the last flush: still in memory when the process dies
        writer.write_message(topic("clock").resolved(), 10**6 + k, ts["rosgraph_msgs/msg/Clock"](clock=_time(float(k))))
    # Simulate SIGKILL: copy the file as the disk holds it now, without closing the writer.
    killed = tmp_path / "killed"
    killed.mkdir()
    shutil.copy(tmp_path / "bag" / "bag.mcap", killed / "killed.mcap")
    bag = open_bag(killed)
    assert not bag.complete and bag.message_count == flushed == 120
    writer.close()


# -- the reference bag ---------------------------------------------------------------------------


def test_reference_bag_is_small_and_records_every_contract_topic(expected):
    size = sum(f.stat().st_size for f in REFERENCE.iterdir())
    assert size < 5 * 2**20
    bag = open_bag(REFERENCE)
    samples = expected["samples"]
    for key in ("setpoint", "measured_output", "manipulated_input", "clock"):
        assert bag.counts[topic(key).resolved()] == samples
    assert bag.counts[topic("diagnostics").resolved()] >= 1 and bag.counts[topic("estimates").resolved()] >= 1
    assert bag.counts[topic(RUN_CONFIG_KEY).resolved()] == 1
    config = bag.run_config()
    assert config.scenario == "full" and config.seed == 1 and config.samples == samples


def test_reference_bag_rediagnosed_offline_gives_the_expected_and_the_recorded_verdicts(reference_result, expected):
    bag, result = reference_result
    assert result.config_origin == "bag"
    final = result.final
    assert final.kind == VERDICT and final.window == {"window_samples": 8192, "first_sample": 0, "last_sample": 8191}
    assert final.window == expected["node_set"]["window"]
    # the reference report was written by pmr_ros 0.1 (flat classic fields) on another machine:
    # flags, delays and verdicts exact, numbers within compare_diagnoses' tolerance
    offline_elements = diagnosis_to_json(final.diagnosis)["elements"].items()
    offline = {name: e["classic"] | {"verdict": e["verdict"]} for name, e in offline_elements}
    keys = (
        "gain_ratio",
        "tau_index",
        "delay_mismatch_samples",
        "gain_mismatch",
        "tau_mismatch",
        "delay_mismatch",
        "verdict",
    )
    reference = {name: {k: e[k] for k in keys} for name, e in expected["elements"].items()}
    offline = {name: {k: e[k] for k in keys} for name, e in offline.items()}  # the fields the 0.1 report had
    assert compare_diagnoses(offline, reference) == []
    # ... and exactly what the live diagnostician published on /diagnostics for the same window.
    assert result.comparisons and result.all_equal
    assert result.warnings == []


def test_reference_verdicts_match_the_injected_mismatch(reference_result, expected):
    _, result = reference_result
    config = load_config()
    mismatch = config.mismatch.for_scenario("full")
    for j, (name, diagnosed) in enumerate(result.final.diagnosis.elements.items()):
        i, k = divmod(j, 2)
        element = diagnosed.classic
        assert element.gain_mismatch and element.gain_direction == (
            "higher" if mismatch.gain_pct[i, k] > 0 else "lower"
        ), name
        assert element.tau_mismatch and element.tau_direction == (
            "larger" if mismatch.time_constant_pct[i, k] > 0 else "smaller"
        ), name
        assert element.delay_mismatch_samples == mismatch.delay_samples[i, k], name
        assert expected["injected"][name]["delay_samples"] == mismatch.delay_samples[i, k]


def test_an_independent_mcap_reader_decodes_every_message_of_the_reference_bag():
    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory

    counts: dict[str, int] = {}
    with (REFERENCE / "wood_berry_full.mcap").open("rb") as handle:
        reader = make_reader(handle, decoder_factories=[DecoderFactory()])
        summary = reader.get_summary()
        assert {s.encoding for s in summary.schemas.values()} == {"ros2msg"} and all(
            s.data for s in summary.schemas.values()
        )
        assert {c.message_encoding for c in summary.channels.values()} == {"cdr"}
        for schema, channel, _message, decoded in reader.iter_decoded_messages():
            counts[channel.topic] = counts.get(channel.topic, 0) + 1
            if channel.topic == topic("estimates").resolved():
                assert len(decoded.position) == 12 and decoded.name[0] == "G11/gain_ratio"
            elif schema.name == "sensor_msgs/msg/JointState":
                assert len(decoded.position) == 2 and decoded.header.stamp.nanosec == 0
            elif schema.name == "diagnostic_msgs/msg/DiagnosticArray":
                assert len(decoded.status) == 4 and decoded.status[0].values[0].key == "verdict"
            elif schema.name == "std_msgs/msg/String":
                assert "ros__parameters" in decoded.data
            assert channel.metadata["offered_qos_profiles"]
    assert counts == open_bag(REFERENCE).counts


def test_metadata_yaml_is_rosbag2_jazzy_metadata():
    info = yaml.safe_load((REFERENCE / "metadata.yaml").read_text())["rosbag2_bagfile_information"]
    assert info["version"] == 9 and info["storage_identifier"] == "mcap"
    assert info["relative_file_paths"] == ["wood_berry_full.mcap"]
    assert info["message_count"] == sum(t["message_count"] for t in info["topics_with_message_count"])
    topics = {t["topic_metadata"]["name"]: t["topic_metadata"] for t in info["topics_with_message_count"]}
    # the model topics and the measured disturbances joined the contract after the reference bag was recorded
    later = {topic(key).resolved() for key in ("proposed_model", "active_model", "disturbance")}
    assert set(topics) == {t.name for t in recorded_topics().values()} - later
    for t in recorded_topics().values():
        if t.name in later:
            continue
        meta = topics[t.name]
        assert meta["type"] == t.type and meta["serialization_format"] == "cdr"
        assert meta["type_description_hash"].startswith("RIHS01_")
        (qos,) = meta["offered_qos_profiles"]  # v9: a list of mappings, as Jazzy writes it
        assert (
            qos["reliability"] == t.qos.reliability
            and qos["durability"] == t.qos.durability
            and qos["depth"] == t.qos.depth
        )
        assert qos["history"] == "keep_last" and set(qos["deadline"]) == {"sec", "nsec"}
    assert set(info["custom_data"]) == set(CUSTOM_DATA_KEYS)


# -- offline diagnosis ---------------------------------------------------------------------------


def test_offline_diagnosis_of_a_bag_with_another_config(tmp_path, expected):
    # --config: a plain system file; the diagnostician's defaults (16384-sample window, 8192 minimum) apply.
    bag = open_bag(REFERENCE)
    config, origin = bag_configuration(bag, str(ROOT / "config" / "wood_berry.yaml"))
    settings = config.diagnostician
    assert (
        origin.endswith("wood_berry.yaml")
        and settings.window_samples == 16384
        and settings.update_period_samples == 1024
    )
    result = diagnose_bag(bag, str(ROOT / "config" / "wood_berry.yaml"), method="classic")
    assert [o.window["last_sample"] for o in result.outcomes] == list(range(1023, 8192, 1024))
    assert [o.kind for o in result.outcomes] == [INSUFFICIENT] * 7 + [VERDICT]
    assert result.comparisons[0]["equal"]  # same whole-run window as the live one
    # the shipped config's own method (parametric) differs from the recorded one: nothing to compare, and it says so
    other = diagnose_bag(bag, str(ROOT / "config" / "wood_berry.yaml"))
    assert other.final_diagnosis.method == "parametric" and other.comparisons == []
    assert "not compared" in other.warnings[0]


def test_compare_flags_a_different_verdict(reference_result):
    _, result = reference_result
    final = result.outcomes[-1]

    def with_g11_gain_ratio(factor):
        element = final.diagnosis.elements["G11"]
        classic = replace(element.classic, gain_ratio=element.classic.gain_ratio * factor)
        diagnosis = replace(
            final.diagnosis, elements={**final.diagnosis.elements, "G11": replace(element, classic=classic)}
        )
        return [*result.outcomes[:-1], replace(final, diagnosis=diagnosis)]

    (entry,) = compare(with_g11_gain_ratio(1 + 1e-12), result.recorded)
    assert entry["equal"]  # another machine's last digits are no disagreement
    (entry,) = compare(with_g11_gain_ratio(1 + 1e-4), result.recorded)
    assert not entry["equal"] and entry["differences"][0].startswith("G11.classic.gain_ratio")


def test_required_topics_are_r_u_y():
    assert required_topics() == {
        topic(k).resolved(): topic(k).type for k in ("setpoint", "manipulated_input", "measured_output")
    }


def test_shared_windowing_schedule_and_outcomes(wood_berry):
    model = wood_berry.model
    names = {"r": model.output_names, "u": model.input_names, "y": model.output_names}
    aligner = SampleAligner(1.0, names, {s: s for s in "ruy"}, capacity=100, max_lag_samples=3)
    assert window_info(aligner, 100) == {"window_samples": 0}
    due = []
    for k in range(8):
        for s in "ruy":
            due.append(
                offer_signal(
                    aligner, s, stamp_s=float(k), names=names[s], values=[0.0, 0.0], update_period_samples=4
                ).update_due
            )
    assert sum(due) == 2  # samples 3 and 7 complete
    assert window_info(aligner, 5) == {"window_samples": 5, "first_sample": 3, "last_sample": 7}
    small = replace(wood_berry, diagnostician=replace(wood_berry.diagnostician, window_samples=100, min_samples=50))
    outcome = evaluate_window(aligner, small)
    assert outcome.kind == INSUFFICIENT and "8 unbroken samples, need 50" in outcome.reason and outcome.stamp_s == 7.0
    for k in range(8, 13):
        offer = offer_signal(
            aligner, "y", stamp_s=float(k), names=names["y"], values=[0.0, 0.0], update_period_samples=4
        )
    assert offer.newly_lagging is None or "stopped" in offer.newly_lagging
    assert evaluate_window(aligner, small).kind == STALE


def test_layout_readers_work_on_rosbags_messages(reference_result):
    bag, _ = reference_result
    (message,) = list(bag.messages({topic("diagnostics").resolved()}))
    diagnosis, info = diagnosis_from_array(bag.decode(message), "pmr_diagnostician")
    assert diagnosis.status == "ok" and set(info["levels"].values()) == {"ERROR"}
    (est,) = list(bag.messages({topic("estimates").resolved()}))
    assert read_estimates(bag.decode(est))["G21"]["delay_mismatch_samples"] == 2.0
    assert level_name(b"\x01") == level_name(1) == "WARN"


# -- bad input: one line, non-zero exit, no traceback ---------------------------------------------


def _cli_error(capsys, argv: list[str]) -> tuple[int, str]:
    code = main(argv)
    captured = capsys.readouterr()
    assert "Traceback" not in captured.err + captured.out
    return code, captured.err.strip()


def _bad_inputs(tmp_path: Path, wood_berry) -> dict[str, tuple[Path, str]]:
    config = RunConfig(wood_berry.parameters)
    cases = {}
    (tmp_path / "notes.txt").write_text("hello")
    cases["a file"] = (tmp_path / "notes.txt", "not a bag")
    (tmp_path / "folder").mkdir()
    cases["a folder"] = (tmp_path / "folder", "not a rosbag2 bag")
    cases["nothing"] = (tmp_path / "nowhere", "no such bag")
    BagWriter(tmp_path / "empty").close()
    cases["empty bag"] = (tmp_path / "empty", "empty")
    _write_small_bag(tmp_path / "no_u", 20, skip=("manipulated_input",), config=config).close()
    cases["missing topic"] = (
        tmp_path / "no_u",
        "topic /pmr/manipulated_input (sensor_msgs/msg/JointState) is not in the bag",
    )
    wrong = dict(recorded_topics())
    wrong["setpoint"] = wrong[RUN_CONFIG_KEY].__class__(**{**wrong["setpoint"].__dict__, "type": "std_msgs/msg/String"})
    writer = BagWriter(tmp_path / "wrong", topics=wrong)
    writer.write_message("/pmr/setpoint", 1, typestore().types["std_msgs/msg/String"](data="x"))
    writer.close()
    cases["wrong type"] = (
        tmp_path / "wrong",
        "topic /pmr/setpoint has type std_msgs/msg/String, expected sensor_msgs/msg/JointState",
    )
    # (a truncated MCAP or a damaged summary is recovered: test_bag_faults.py)
    (tmp_path / "junk").mkdir()
    (tmp_path / "junk" / "junk.mcap").write_bytes(b"not an mcap file at all" * 10)
    cases["not MCAP"] = (tmp_path / "junk", "not a readable MCAP file")
    shutil.copytree(REFERENCE, tmp_path / "bad_metadata")
    (tmp_path / "bad_metadata" / "metadata.yaml").write_text("rosbag2_bagfile_information:\n  version: [unclosed\n")
    (tmp_path / "bad_metadata" / "wood_berry_full.mcap").write_bytes(b"\x89MCAP0\r\n" + b"\x00" * 64)
    cases["bad metadata.yaml and storage"] = (tmp_path / "bad_metadata", "cannot read the bag")
    (tmp_path / "sqlite_junk").mkdir()
    (tmp_path / "sqlite_junk" / "x.db3").write_bytes(b"this is not a database" * 100)
    cases["sqlite3 junk"] = (tmp_path / "sqlite_junk", "x.db3 is not a readable rosbag2 sqlite3 file")
    return cases


def test_bad_bags_give_one_clear_line_and_a_non_zero_exit(tmp_path, capsys, wood_berry):
    for case, (path, words) in _bad_inputs(tmp_path, wood_berry).items():
        code, err = _cli_error(capsys, ["diagnose", str(path)])
        assert code == 2, (case, err)
        assert err.startswith("pmr-ros: error: ") and "\n" not in err, (case, err)
        assert words in err, (case, err)


def test_diagnose_writes_json_and_needs_a_configuration(tmp_path, capsys, wood_berry):
    code = main(["diagnose", str(REFERENCE), "--json", str(tmp_path / "report.json")])
    out = capsys.readouterr().out
    assert code == 0 and "1 of 1 verdict windows agree" in out
    report = json.loads((tmp_path / "report.json").read_text())
    assert report["bag"]["configuration"] == "bag" and report["recorded_comparison"]["different"] == []
    _write_small_bag(tmp_path / "no_config", 20).close()
    code, err = _cli_error(capsys, ["diagnose", str(tmp_path / "no_config")])
    assert code == 2 and "holds no run configuration; pass --config" in err
