"""Faults in recorded data, without ROS: what survives a killed recorder, a late publisher, a wrong --config.

Every bag here holds a real closed-loop run (the batch core's Wood-Berry data), written the way the recorder
writes it; each test checks the data or the verdict that survives, or the one line a bad input gets.
"""

from __future__ import annotations

import copy
import json
import shutil
from functools import cache
from pathlib import Path

import numpy as np
import pytest

from pmr_ros.bag.reader import open_bag
from pmr_ros.bag.repair import reindex
from pmr_ros.bag.storage import BagError, RunConfig, typestore
from pmr_ros.bag.writer import BagWriter
from pmr_ros.cli import main
from pmr_ros.config import load_config, parse_config
from pmr_ros.contract.layout import read_signal
from pmr_ros.contract.topics import topic
from pmr_ros.contract.windowing import STALE, VERDICT
from pmr_ros.core.results import Diagnosis
from pmr_ros.core.results.codec import status_key_values
from pmr_ros.core.sim.closed_loop import simulate
from pmr_ros.service.bag_diagnosis import compare, diagnose_bag, judged_config

ROOT = Path(__file__).resolve().parents[1]
REFERENCE = ROOT / "bags" / "wood_berry_full"
SAMPLES = 8192
SIGNALS = (("measured_output", "y"), ("setpoint", "r"), ("manipulated_input", "u"))


@cache
def _record(samples: int = SAMPLES):
    return simulate(load_config(), samples=samples)


def _run_params(planned: int) -> dict:
    """The parameters ``pmr-ros run --bag --samples planned`` records: one diagnosis of the whole run.

    Without the control impact (``impact.samples`` 0): no test here checks it, and each diagnosis of a bag with a
    mismatch would simulate nine closed loops of 4,096 samples for it (test_bag_ros and test_nodes check it).
    """
    params = copy.deepcopy(load_config().parameters)
    params["run"]["samples"] = planned
    params["diagnostician"].update(window_samples=planned, update_period_samples=planned, min_samples=planned)
    params["impact"]["samples"] = 0
    return params


def _time(seconds: float):
    ns = int(round(seconds * 1e9))
    return typestore().types["builtin_interfaces/msg/Time"](sec=ns // 10**9, nanosec=ns % 10**9)


def _signal(k: int, values, names):
    ts = typestore().types
    return ts["sensor_msgs/msg/JointState"](
        header=ts["std_msgs/msg/Header"](stamp=_time(float(k)), frame_id="wood_berry"),
        name=list(names),
        position=np.ascontiguousarray(values, dtype=float),
        velocity=np.zeros(0),
        effort=np.zeros(0),
    )


def _messages(samples: int, *, late_u: int = 0, bad=None):
    """``(key, k, values)`` in arrival order; with ``late_u``, u's first samples arrive after r and y passed them."""
    rec = _record(max(samples, SAMPLES))
    data = {"y": rec.y, "r": rec.r, "u": rec.u}
    order = []
    for k in range(samples):
        for key, s in SIGNALS:
            if not (s == "u" and k < late_u):
                order.append((key, k, data[s][k]))
        if k == late_u - 1 or (late_u and k == min(samples, 2 * late_u) - 1 and False):
            order += [("manipulated_input", j, data["u"][j]) for j in range(late_u)]
    for key, k, values, after in bad or ():  # a message inserted after that of sample ``after`` of its topic
        position = next(i for i, (other, j, _) in enumerate(order) if (other, j) == (key, after)) + 1
        order.insert(position, (key, k, values))
    return order


def _write_bag(path: Path, messages, *, params: dict | None, storage: str = "mcap", close: bool = True) -> BagWriter:
    config = load_config()
    names = {
        "measured_output": config.model.output_names,
        "setpoint": config.model.output_names,
        "manipulated_input": config.model.input_names,
    }
    writer = BagWriter(path, storage=storage, flush_period_s=3600)
    if params is not None:
        writer.write_run_config(RunConfig(params, source="test"), 1)
    for n, (key, k, values) in enumerate(messages):
        if key == "measured_output":
            clock = typestore().types["rosgraph_msgs/msg/Clock"](clock=_time(float(k)))
            writer.write_message(topic("clock").resolved(), 10 + 10 * n, clock)
        channel_names = names[key][: len(values)] if len(values) <= len(names[key]) else [*names[key], "extra"]
        writer.write_message(topic(key).resolved(), 11 + 10 * n, _signal(k, values, channel_names))
    writer.flush()
    if close:
        writer.close()
    return writer


def _killed_copy(writer: BagWriter, tmp_path: Path, name: str = "killed") -> Path:
    """The bag directory as the disk holds it when its recorder dies now (SIGKILL: no summary, no metadata.yaml)."""
    killed = tmp_path / name
    killed.mkdir()
    for f in writer.path.iterdir():
        shutil.copy(f, killed / f.name)
    writer.close()
    return killed


def _one_line_error(capsys, argv) -> tuple[int, str]:
    code = main(argv)
    captured = capsys.readouterr()
    assert "Traceback" not in captured.out + captured.err
    err = captured.err.strip()
    assert err.startswith("pmr-ros: error: ") and "\n" not in err, err
    return code, err


# -- a late publisher ---------------------------------------------------------------------------


def test_a_late_publishers_backlog_recorded_after_r_and_y_still_gives_a_verdict(tmp_path, capsys):
    """The transient-local backlog of u (600 samples) arrives after r and y passed sample 599: every sample is kept."""
    _write_bag(tmp_path / "late", _messages(SAMPLES, late_u=600), params=_run_params(SAMPLES))
    result = diagnose_bag(open_bag(tmp_path / "late"))
    final = result.final
    assert final.kind == VERDICT and final.window == {"window_samples": SAMPLES, "first_sample": 0, "last_sample": 8191}
    assert result.gaps == 0 and result.drops.total == 0
    # the same verdicts as the batch core's diagnosis of the whole run
    rec = _record()
    expected = _batch_diagnosis(rec.r, rec.u, rec.y)
    assert {n: e.verdict for n, e in final.diagnosis.elements.items()} == {
        n: e.verdict for n, e in expected.elements.items()
    }
    assert main(["diagnose", str(tmp_path / "late")]) == 0
    assert "mismatch" in capsys.readouterr().out


def _batch_diagnosis(r, u, y) -> Diagnosis:
    from pmr_ros.core.pmr.diagnosis import diagnose

    config = load_config()
    return diagnose(r, u, y, model=config.model, pmr=config.pmr, parametric=config.parametric)


# -- recordings cut short ------------------------------------------------------------------------


def test_a_killed_run_bag_is_judged_on_what_it_holds(tmp_path, capsys):
    """``pmr-ros run --bag`` killed at sample 11120 of 16384: a verdict, with how to change the minimum."""
    writer = _write_bag(tmp_path / "run", _messages(11121), params=_run_params(16384), close=False)
    killed = _killed_copy(writer, tmp_path)
    bag = open_bag(killed)
    assert not bag.complete and bag.counts[topic("setpoint").resolved()] == 11121
    result = diagnose_bag(bag)
    assert result.config.diagnostician.min_samples == 8192  # the declared default, not the planned 16384
    assert result.final.kind == VERDICT and result.final.window["window_samples"] == 11121
    assert main(["diagnose", str(killed)]) == 0
    out = capsys.readouterr().out
    assert "the bag holds 11121 of the 16384 samples its run planned" in out and "--min-samples N" in out
    # --min-samples: the user's threshold wins
    assert main(["diagnose", str(killed), "--min-samples", "12000"]) == 3
    assert "INSUFFICIENT DATA: 11121 unbroken samples, need 12000" in capsys.readouterr().out


def test_judged_config_keeps_a_deliberate_minimum(wood_berry):
    # a live graph's recording (min_samples 8192 of a 16384 window): its minimum stays, whatever the bag holds
    config, note = judged_config(wood_berry, held=3000, origin="bag")
    assert config is wood_berry and note is None
    whole = parse_config(_run_params(16384), "bag")
    assert judged_config(whole, held=16384, origin="bag") == (whole, None)  # nothing was cut
    with pytest.raises(BagError, match="--min-samples 20000: must not exceed diagnostician.window_samples = 16384"):
        judged_config(whole, held=100, origin="bag", min_samples=20000)


@pytest.mark.parametrize("metadata", [False, True], ids=["without metadata.yaml", "with metadata.yaml"])
def test_a_truncated_mcap_is_recovered_with_or_without_its_metadata(tmp_path, capsys, metadata):
    shutil.copytree(REFERENCE, tmp_path / "cut")
    mcap = tmp_path / "cut" / "wood_berry_full.mcap"
    mcap.write_bytes(mcap.read_bytes()[: mcap.stat().st_size // 2])
    if not metadata:
        (tmp_path / "cut" / "metadata.yaml").unlink()
    bag = open_bag(tmp_path / "cut")
    held = bag.counts[topic("setpoint").resolved()]
    assert not bag.complete and 3000 < held < 4096 and bag.run_config() is not None
    stamps = [read_signal(bag.decode(m))[0] for m in bag.messages({topic("setpoint").resolved()})]
    assert stamps == [float(k) for k in range(held)]  # every whole message, in order
    assert main(["diagnose", str(tmp_path / "cut")]) == 3
    out = capsys.readouterr().out
    assert f"{held} unbroken samples, need 8192" in out and "--min-samples N judges it on fewer" in out
    assert "is incomplete (" in out and "read as far as it is whole" in out
    assert main(["diagnose", str(tmp_path / "cut"), "--min-samples", "3000"]) == 0


def test_a_damaged_summary_loses_no_message(tmp_path, capsys):
    shutil.copytree(REFERENCE, tmp_path / "damaged")
    mcap = tmp_path / "damaged" / "wood_berry_full.mcap"
    data = bytearray(mcap.read_bytes())
    data[-200:-100] = b"\xff" * 100  # the summary section
    mcap.write_bytes(bytes(data))
    bag = open_bag(tmp_path / "damaged")
    assert not bag.complete and bag.counts == open_bag(REFERENCE).counts
    assert main(["diagnose", str(tmp_path / "damaged")]) == 0
    assert "1 of 1 verdict windows agree" in capsys.readouterr().out


def test_a_half_written_chunk_ends_the_recovery_there(tmp_path):
    """The file's tail overwritten with junk (a chunk the recorder was writing when it died): all before it is kept."""
    shutil.copytree(REFERENCE, tmp_path / "junk_tail")
    mcap = tmp_path / "junk_tail" / "wood_berry_full.mcap"
    data = bytearray(mcap.read_bytes())
    middle = len(data) // 2
    data[middle:] = np.random.default_rng(1).integers(0, 256, len(data) - middle, dtype=np.uint8).tobytes()
    mcap.write_bytes(bytes(data))
    bag = open_bag(tmp_path / "junk_tail")  # metadata.yaml is there: rosbags refuses, the scan recovers
    reference = {(m.topic, m.log_time_ns): m.data for m in open_bag(REFERENCE).messages()}
    kept = list(bag.messages())
    assert not bag.complete and 0 < len(kept) < len(reference)
    assert all(reference[(m.topic, m.log_time_ns)] == m.data for m in kept)


def test_garbage_is_no_bag(tmp_path, capsys):
    (tmp_path / "junk").mkdir()
    (tmp_path / "junk" / "junk.mcap").write_bytes(b"\x89MCAP0\r\n" + bytes(range(256)) * 4)
    code, err = _one_line_error(capsys, ["diagnose", str(tmp_path / "junk")])
    assert code == 2 and "junk" in err and ("not a readable MCAP file" in err or "empty" in err)


def test_a_killed_sqlite3_recording_is_read_from_its_committed_rows(tmp_path, capsys):
    writer = _write_bag(
        tmp_path / "sq", _messages(SAMPLES), params=_run_params(SAMPLES), storage="sqlite3", close=False
    )
    # rows after the last commit are lost with the process, as in a real SIGKILL
    for k in range(SAMPLES, SAMPLES + 5):
        writer.write_message(
            topic("clock").resolved(), 10**12 + k, typestore().types["rosgraph_msgs/msg/Clock"](clock=_time(k))
        )
    killed = _killed_copy(writer, tmp_path)
    assert not (killed / "metadata.yaml").exists()
    bag = open_bag(killed)
    assert not bag.complete and bag.storage == "sqlite3"
    assert bag.counts[topic("clock").resolved()] == SAMPLES and bag.counts[topic("setpoint").resolved()] == SAMPLES
    assert bag.run_config().params == _run_params(SAMPLES)
    files = {p.name: p.read_bytes() for p in killed.iterdir()}
    assert main(["diagnose", str(killed)]) == 0
    assert "is incomplete (no metadata.yaml" in capsys.readouterr().out
    assert {
        p.name: p.read_bytes() for p in killed.iterdir()
    } == files  # read from a copy: the user's files as they were


@pytest.mark.parametrize("storage", ["mcap", "sqlite3"])
def test_reindex_writes_a_complete_copy_and_leaves_the_original(tmp_path, capsys, storage):
    writer = _write_bag(tmp_path / "b", _messages(300), params=_run_params(300), storage=storage, close=False)
    killed = _killed_copy(writer, tmp_path)
    before = {p.name: p.read_bytes() for p in killed.iterdir()}
    assert main(["reindex", str(killed), "--out", str(tmp_path / "fixed")]) == 0
    assert "(not closed by its recorder) written to" in capsys.readouterr().err
    assert {p.name: p.read_bytes() for p in killed.iterdir()} == before
    fixed = open_bag(tmp_path / "fixed")
    assert fixed.complete and fixed.storage == storage and (tmp_path / "fixed" / "metadata.yaml").is_file()
    original = open_bag(killed)
    assert fixed.counts == original.counts
    assert [(m.topic, m.log_time_ns, m.data) for m in fixed.messages()] == [
        (m.topic, m.log_time_ns, m.data) for m in original.messages()
    ]
    assert fixed.custom_data["pmr_ros.samples"] == "300" and fixed.run_config().params == _run_params(300)
    code, err = _one_line_error(capsys, ["reindex", str(killed), "--out", str(tmp_path / "fixed")])
    assert code == 2 and "exists already; pass --force" in err


def test_reindex_refuses_a_topic_outside_the_contract(tmp_path):
    bag = open_bag(REFERENCE)
    bag.topics["/other"] = "std_msgs/msg/String"
    with pytest.raises(BagError, match="topic /other is not one of the pmr_ros contract"):
        reindex(bag, tmp_path / "x")


# -- what the console says -----------------------------------------------------------------------


def test_a_bag_of_another_system_is_one_line_naming_topic_field_and_widths(tmp_path, capsys):
    code, err = _one_line_error(
        capsys, ["diagnose", str(REFERENCE), "--config", str(ROOT / "config/three_by_three.yaml")]
    )
    assert code == 2
    assert (
        "/pmr/setpoint carries 2 values (x_D, x_B) in position where the configuration "
        f"({ROOT / 'config/three_by_three.yaml'}) expects 3 (y1, y2, y3)" in err
    )


def test_drops_are_counted_per_topic_on_the_console_with_examples(tmp_path, capsys):
    nan = [np.nan, 0.0]
    bad = [
        ("measured_output", 101, nan, 100),  # y(101) non-finite: y(101) missing, a gap
        ("measured_output", 100, [1.0, 2.0], 100),  # duplicated stamp
        ("measured_output", 50, [1.0, 2.0], 300),  # out of order
        ("manipulated_input", 200, [1.0, 2.0, 3.0], 200),  # wrong length (after the good u(200))
    ]
    _write_bag(tmp_path / "bad", _messages(SAMPLES, bad=bad), params=_run_params(SAMPLES))
    assert main(["diagnose", str(tmp_path / "bad"), "--json", str(tmp_path / "r.json")]) == 0
    out = capsys.readouterr().out
    assert (
        "dropped: y on /pmr/measured_output: 3 messages dropped (1 duplicated, 1 non-finite value, 1 out-of-order)"
        in out
    )
    assert "  e.g. y on /pmr/measured_output: non-finite value x_D=nan; message dropped" in out
    assert "  e.g. y on /pmr/measured_output: out-of-order stamp 50 s (sample 50, newest is 300)" in out
    assert "dropped: u on /pmr/manipulated_input: 1 message dropped (1 wrong number of values)" in out
    report = json.loads((tmp_path / "r.json").read_text())
    assert report["dropped_messages"]["y on /pmr/measured_output"]["by_kind"] == {
        "non-finite value": 1,
        "duplicated": 1,
        "out-of-order": 1,
    }


def test_a_start_up_window_the_live_node_could_not_diagnose_is_no_disagreement(tmp_path, capsys):
    """A normal recording: STALE while the publishers matched, then the verdict: exit 0, not 4."""
    path = tmp_path / "normal"
    _write_bag(path, _messages(SAMPLES), params=_run_params(SAMPLES), close=False).close()
    offline = diagnose_bag(open_bag(path))
    config = offline.config
    stale = Diagnosis.insufficient(
        method="parametric", models=config.model.element_models(), reason="no u received", samples=3
    )
    writer = BagWriter(tmp_path / "with_diagnostics", flush_period_s=3600)
    for message in open_bag(path).messages():
        writer.write_raw(message.topic, message.log_time_ns, message.data)
    window = {"window_samples": 3, "first_sample": 0, "last_sample": 2}
    writer.write_message(topic("diagnostics").resolved(), 10**12, _diagnostics(stale, window, STALE))
    final = offline.final
    writer.write_message(topic("diagnostics").resolved(), 10**12 + 1, _diagnostics(final.diagnosis, final.window, "ok"))
    writer.close()
    result = diagnose_bag(open_bag(tmp_path / "with_diagnostics"))
    assert len(result.recorded) == 2 and result.not_diagnosed_live == 1
    assert len(result.comparisons) == 1 and result.all_equal
    assert main(["diagnose", str(tmp_path / "with_diagnostics")]) == 0
    out = capsys.readouterr().out
    assert "1 of 1 verdict windows agree offline" in out and "1 window(s) without a live verdict" in out
    # a recorded verdict whose window the offline diagnosis does not have is still a disagreement
    (entry,) = compare([], result.recorded)
    assert not entry["equal"] and entry["offline_status"] == "not diagnosed offline"


def _diagnostics(diagnosis: Diagnosis, window: dict, state: str):
    ts = typestore().types
    statuses = []
    for name, element in diagnosis.elements.items():
        pairs = dict(status_key_values(diagnosis, element, state=state, window=window))
        statuses.append(
            ts["diagnostic_msgs/msg/DiagnosticStatus"](
                level=3 if state == STALE else 2,
                name=f"pmr_diagnostician: {name}",
                message=state,
                hardware_id="wood_berry",
                values=[ts["diagnostic_msgs/msg/KeyValue"](key=k, value=v) for k, v in pairs.items()],
            )
        )
    header = ts["std_msgs/msg/Header"](stamp=_time(0.0), frame_id="")
    return ts["diagnostic_msgs/msg/DiagnosticArray"](header=header, status=statuses)


def test_diagnose_checks_json_before_reading_the_bag(tmp_path, capsys):
    code, err = _one_line_error(capsys, ["diagnose", str(REFERENCE), "--json", str(tmp_path / "no" / "r.json")])
    assert code == 2 and f"--json {tmp_path / 'no' / 'r.json'}: cannot write: No such file or directory" in err
    assert capsys.readouterr().out == ""  # nothing diagnosed
    code, err = _one_line_error(capsys, ["diagnose", str(REFERENCE), "--json", str(tmp_path)])
    assert code == 2 and "is a folder, not a file" in err


def test_insufficient_data_names_the_configured_method(tmp_path, capsys):
    writer = _write_bag(tmp_path / "short", _messages(300), params=_run_params(300))
    assert writer.path.exists()
    for method in ("parametric", "classic"):
        assert main(["diagnose", str(tmp_path / "short"), "--method", method]) == 3
        head = capsys.readouterr().out.splitlines()[0]
        assert f"({method} PMR)" in head
