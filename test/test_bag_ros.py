"""Bags with ROS: run --bag, replay into a live diagnostician, the recorder as a process (SIGINT/SIGTERM/SIGKILL).

Each test has its own ROS domain (test/ros_fixtures.py); child processes are always killed.
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import time
from pathlib import Path

import pytest
import rclpy  # noqa: F401  # the ROS 2 wheels are part of the set-up (test.sh): missing is an error, not a skip
from ros_fixtures import console_script, spin_until  # noqa: E402

from pmr_ros.bag.offline import diagnose_bag  # noqa: E402
from pmr_ros.bag.reader import open_bag  # noqa: E402
from pmr_ros.bag.schema import RUN_CONFIG_KEY  # noqa: E402
from pmr_ros.cli import main  # noqa: E402
from pmr_ros.config import flatten_parameters, parse_config  # noqa: E402
from pmr_ros.contract.layout import diagnosis_from_array  # noqa: E402
from pmr_ros.contract.topics import topic  # noqa: E402
from pmr_ros.core.results import compare_diagnoses  # noqa: E402
from pmr_ros.ros.parameters import parameter_overrides  # noqa: E402

pytestmark = pytest.mark.ros

ROOT = Path(__file__).resolve().parents[1]
REFERENCE = ROOT / "bags" / "wood_berry_full"
EXPECTED = json.loads((ROOT / "bags" / "wood_berry_full.expected.json").read_text())
SIGNAL_TOPICS = [topic(k).name for k in ("setpoint", "manipulated_input", "measured_output")]


def _diagnostician(context, bag):
    from pmr_ros.nodes.pmr_diagnostician import PmrDiagnosticianNode

    params = flatten_parameters(bag.run_config().params)
    return PmrDiagnosticianNode(context=context, parameter_overrides=parameter_overrides(params))


def _final_numbers(node, last_sample: int):
    msg = node.last_published
    diagnosis, info = diagnosis_from_array(msg, node.get_name())
    assert info.get("last_sample") == last_sample, info
    return classic_numbers(diagnosis.to_dict()["elements"]), info


CLASSIC_KEYS = ("gain_ratio", "tau_index", "delay_mismatch_samples", "gain_mismatch", "tau_mismatch", "delay_mismatch")


def classic_numbers(elements: dict) -> dict:
    """The classic numbers, flags and verdict of each element of a serialised diagnosis."""
    return {
        name: {**{k: e["classic"][k] for k in CLASSIC_KEYS}, "verdict": e["verdict"]} for name, e in elements.items()
    }


# The reference report was written by pmr_ros 0.1 (flat classic fields) on another machine.
EXPECTED_NUMBERS = {name: {k: e[k] for k in (*CLASSIC_KEYS, "verdict")} for name, e in EXPECTED["elements"].items()}


def test_replaying_the_reference_bag_into_a_live_diagnostician_gives_the_expected_verdicts(ros_context):
    from rclpy.executors import SingleThreadedExecutor

    from pmr_ros.nodes.bag_player import BagPlayerNode

    bag = open_bag(REFERENCE)
    diagnostician = _diagnostician(ros_context, bag)
    player = BagPlayerNode(bag, context=ros_context)
    executor = SingleThreadedExecutor(context=ros_context)
    for node in (diagnostician, player):
        executor.add_node(node)
    try:
        assert player.wait_for_subscribers(SIGNAL_TOPICS, 10.0, lambda: executor.spin_once(timeout_sec=0.02))
        # Strict lockstep: after each sample the diagnostician takes its r, u and y before the next goes out.
        count = player.play(
            max_samples_per_s=None,
            after_sample=lambda n: spin_until(executor, lambda: diagnostician.messages_received >= 3 * n, 10.0),
        )
        assert count == EXPECTED["samples"]
        assert spin_until(executor, lambda: diagnostician.last_published is not None, 10.0)
        numbers, info = _final_numbers(diagnostician, EXPECTED["samples"] - 1)
        assert compare_diagnoses(numbers, EXPECTED_NUMBERS) == []
        assert info["first_sample"] == 0 and set(info["levels"].values()) == {"ERROR"}
        assert list(diagnostician.warnings) == []
    finally:
        executor.shutdown(timeout_sec=1.0)
        for node in (diagnostician, player):
            node.destroy_node()


def test_pmr_ros_replay_process_drives_a_live_diagnostician(ros_context, tmp_path):
    from rclpy.executors import SingleThreadedExecutor

    bag = open_bag(REFERENCE)
    diagnostician = _diagnostician(ros_context, bag)
    executor = SingleThreadedExecutor(context=ros_context)
    executor.add_node(diagnostician)
    log = open(tmp_path / "replay.log", "w+")  # noqa: SIM115 - closed in finally
    proc = subprocess.Popen(
        [console_script("pmr-ros"), "replay", str(REFERENCE), "--linger", "0.5", "--max-samples-per-second", "500"],
        stdout=log,
        stderr=subprocess.STDOUT,
        env=dict(os.environ),
    )
    last = EXPECTED["samples"] - 1

    def final() -> bool:  # the verdict on the whole run (a STALE status while the replay starts up is not it)
        msg = diagnostician.last_published
        return msg is not None and diagnosis_from_array(msg, diagnostician.get_name())[1].get("last_sample") == last

    try:
        assert spin_until(executor, lambda: final() or proc.poll() is not None, 300.0)
        assert spin_until(executor, final, 30.0), (tmp_path / "replay.log").read_text()
        assert diagnostician.messages_received == 3 * EXPECTED["samples"], list(diagnostician.warnings)[:5]
        numbers, _ = _final_numbers(diagnostician, last)
        assert proc.wait(timeout=60) == 0, (tmp_path / "replay.log").read_text()
        assert compare_diagnoses(numbers, EXPECTED_NUMBERS) == []
        text = (tmp_path / "replay.log").read_text()
        assert "8192 samples" in text and "Traceback" not in text
    finally:
        _stop(proc, log)
        executor.shutdown(timeout_sec=1.0)
        diagnostician.destroy_node()


def test_run_bag_records_the_node_set_and_diagnose_matches_it(ros_domain, tmp_path, capsys):
    samples = 1500
    path = tmp_path / "run_bag"
    argv = [
        "run",
        "--samples",
        str(samples),
        "--bag",
        str(path),
        "--storage",
        "sqlite3",
        "--json",
        str(tmp_path / "run.json"),
    ]
    assert main(argv) == 0
    capsys.readouterr()
    bag = open_bag(path)
    assert bag.complete and bag.storage == "sqlite3"
    for key in ("setpoint", "manipulated_input", "measured_output", "clock"):
        assert bag.counts[topic(key).name] == samples, key
    assert bag.counts[topic("diagnostics").name] >= 1 and bag.counts[topic("estimates").name] >= 1
    config = bag.run_config()
    assert config.samples == samples and config.seed == 1 and config.scenario == "full"
    assert config.params["diagnostician"]["window_samples"] == samples  # the settings the nodes really ran with
    result = diagnose_bag(bag)
    assert result.comparisons and result.all_equal
    # pmr-ros diagnose of the bag reports what pmr-ros run reported, control impact included
    assert main(["diagnose", str(path), "--json", str(tmp_path / "offline.json")]) == 0
    capsys.readouterr()
    run = json.loads((tmp_path / "run.json").read_text())
    offline = json.loads((tmp_path / "offline.json").read_text())
    assert offline["elements"] == run["elements"] and offline["impact"] == run["impact"]  # one machine, one bag: exact
    # Never overwritten without --force; --batch cannot record.
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert "exists already; pass --force" in err and "Traceback" not in err
    assert main(["run", "--batch", "--bag", str(tmp_path / "x")]) == 2
    assert "--bag records the node set's topics" in capsys.readouterr().err


def _stop(proc: subprocess.Popen, log) -> None:
    """Kill a child process that is still running and close its log."""
    if proc.poll() is None:
        proc.kill()
        proc.wait(timeout=5)
    log.close()


def _start_recorder(tmp_path: Path, bag: Path, *extra: str) -> tuple[subprocess.Popen, object]:
    log = open(tmp_path / "record.log", "w+")  # noqa: SIM115 - closed by the caller
    proc = subprocess.Popen(
        [console_script("pmr-ros"), "record", str(bag), "--flush-period", "0.2", *extra],
        stdout=log,
        stderr=subprocess.STDOUT,
        env=dict(os.environ),
    )
    return proc, log


def _publish_to_recorder(ros_context, samples: int, *, publish_config: bool, extra_nodes=()):
    """Publish the first ``samples`` samples of the reference bag to a recorder process; returns the player."""
    from rclpy.executors import SingleThreadedExecutor

    from pmr_ros.nodes.bag_player import BagPlayerNode

    bag = open_bag(REFERENCE)
    player = BagPlayerNode(bag, context=ros_context, publish_config=publish_config)
    executor = SingleThreadedExecutor(context=ros_context)
    for node in (player, *extra_nodes):
        executor.add_node(node)
    assert player.wait_for_subscribers(
        [*SIGNAL_TOPICS, topic("clock").name], 30.0, lambda: executor.spin_once(timeout_sec=0.02)
    ), "the recorder did not subscribe"
    # Pace the samples a little so the recorder (one Python process) never falls a history depth behind.
    player.play(
        should_stop=lambda: sum(player.published.values()) >= 4 * samples + publish_config,
        after_sample=lambda n: executor.spin_once(timeout_sec=0) if n % 50 == 0 else None,
    )
    return player, executor


@pytest.mark.parametrize("how", [signal.SIGINT, signal.SIGTERM])
def test_recorder_process_stopped_by_a_signal_closes_the_bag(ros_context, tmp_path, how):
    samples = 1500
    path = tmp_path / "recorded"
    bag = open_bag(REFERENCE)
    diagnostician = _diagnostician(ros_context, bag) if how == signal.SIGTERM else None
    extra = [diagnostician] if diagnostician else []
    proc, log = _start_recorder(tmp_path, path)
    try:
        player, executor = _publish_to_recorder(
            ros_context, samples, publish_config=how == signal.SIGINT, extra_nodes=extra
        )
        deadline = time.monotonic() + 1.5
        while time.monotonic() < deadline:
            executor.spin_once(timeout_sec=0.05)  # serve the diagnostician's parameter services
        proc.send_signal(how)
        assert proc.wait(timeout=20) == 0
        text = (tmp_path / "record.log").read_text()
        assert "Traceback" not in text
        recorded = open_bag(path)
        assert recorded.complete and (path / "metadata.yaml").is_file()
        for name in [*SIGNAL_TOPICS, topic("clock").name]:
            assert recorded.counts[name] == samples, (name, recorded.counts, text)
        config = recorded.run_config()
        assert config is not None
        # the same model, whatever defaults the recorder's source spelled out
        recorded_model = parse_config(config.params, "recorded").model.element_models()
        assert recorded_model == parse_config(bag.run_config().params, "reference").model.element_models()
        if diagnostician is not None:
            assert "parameters of /pmr_diagnostician" in config.source
        executor.shutdown(timeout_sec=1.0)
        player.destroy_node()
    finally:
        _stop(proc, log)
        if diagnostician is not None:
            diagnostician.destroy_node()


def _wait_until_flushed(path, topic_name: str, count: int, timeout_s: float) -> None:
    deadline = time.monotonic() + timeout_s
    seen = 0
    while time.monotonic() < deadline:
        try:
            seen = open_bag(path).counts.get(topic_name, 0)
        except Exception:  # noqa: BLE001 - a chunk being written may not parse yet
            seen = 0
        if seen >= count:
            return
        time.sleep(0.2)
    raise AssertionError(f"only {seen} of {count} messages on {topic_name} reached the disk in {timeout_s} s")


@pytest.mark.parametrize("storage", ["mcap", "sqlite3"])
def test_recorder_killed_with_sigkill_leaves_everything_before_its_last_flush(ros_context, tmp_path, capsys, storage):
    samples = 2000
    path = tmp_path / "killed"
    proc, log = _start_recorder(tmp_path, path, "--storage", storage)
    try:
        player, executor = _publish_to_recorder(ros_context, samples, publish_config=True)
        # Wait until the recorder's flushes (every 0.2 s) put every message on disk -- read back
        # from the file while it is being written -- then kill it without warning.
        _wait_until_flushed(path, topic("measured_output").name, samples, timeout_s=60.0)
        proc.send_signal(signal.SIGKILL)
        proc.wait(timeout=10)
        assert not (path / "metadata.yaml").exists()
        recorded = open_bag(path)
        assert not recorded.complete and recorded.storage == storage
        for name in [*SIGNAL_TOPICS, topic("clock").name]:
            assert recorded.counts[name] == samples, (name, recorded.counts)
        assert recorded.counts[topic(RUN_CONFIG_KEY).name] == 1 and recorded.run_config() is not None
        stamps = [int(recorded.decode(m).header.stamp.sec) for m in recorded.messages({topic("measured_output").name})]
        assert stamps == list(range(samples))
        # The offline diagnosis reads it too (8192 samples are needed for a verdict: insufficient data, exit 3).
        assert main(["diagnose", str(path)]) == 3
        out = capsys.readouterr().out
        assert "is incomplete (no metadata.yaml" in out and "2000 unbroken samples, need 8192" in out
        executor.shutdown(timeout_sec=1.0)
        player.destroy_node()
    finally:
        _stop(proc, log)


@pytest.mark.parametrize("stop", [signal.SIGINT, signal.SIGTERM], ids=["SIGINT", "SIGTERM"])
def test_run_with_bag_stopped_by_a_signal_closes_the_bag(ros_domain, tmp_path, stop):
    path = tmp_path / "stopped"
    proc = subprocess.Popen(
        [console_script("pmr-ros"), "run", "--samples", "500000", "--bag", str(path)],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        _wait_until_flushed(path, topic("measured_output").name, 1000, timeout_s=60.0)
        proc.send_signal(stop)
        _, err = proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.communicate()
    assert proc.returncode == 130 and "interrupted" in err and "Traceback" not in err, err[-2000:]
    recorded = open_bag(path)
    assert recorded.complete and (path / "metadata.yaml").exists()  # closed, not merely flushed
    assert recorded.counts[topic("measured_output").name] >= 1000 and recorded.run_config() is not None


def test_a_run_bag_killed_with_sigkill_gets_a_verdict_offline_and_replays(ros_context, tmp_path, capsys):
    """``pmr-ros run --bag`` dies mid-run: the bag is judged on what it holds, and a replay publishes all of it."""
    from rclpy.executors import SingleThreadedExecutor

    path = tmp_path / "run"
    proc = subprocess.Popen(
        [console_script("pmr-ros"), "run", "--bag", str(path), "--storage", "sqlite3"],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    try:
        _wait_until_flushed(path, topic("measured_output").name, 9000, timeout_s=120.0)
        proc.send_signal(signal.SIGKILL)
        proc.wait(timeout=10)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait(timeout=10)
    recorded = open_bag(path)
    held = min(recorded.counts[name] for name in SIGNAL_TOPICS)
    assert not recorded.complete and 9000 <= held < 16384
    assert main(["diagnose", str(path)]) == 0
    out = capsys.readouterr().out
    assert f"the bag holds {held} of the 16384 samples its run planned" in out and "mismatch" in out
    # replay what it holds into a live diagnostician
    diagnostician = _diagnostician(ros_context, recorded)
    from pmr_ros.nodes.bag_player import BagPlayerNode

    player = BagPlayerNode(recorded, context=ros_context)
    executor = SingleThreadedExecutor(context=ros_context)
    for node in (diagnostician, player):
        executor.add_node(node)
    try:
        assert player.wait_for_subscribers(SIGNAL_TOPICS, 10.0, lambda: executor.spin_once(timeout_sec=0.02))
        count = player.play(
            max_samples_per_s=None,
            after_sample=lambda n: spin_until(executor, lambda: diagnostician.messages_received >= 3 * n, 10.0),
        )
        assert count >= held and diagnostician.aligner.stretch_last == held - 1
    finally:
        executor.shutdown(timeout_sec=1.0)
        for node in (diagnostician, player):
            node.destroy_node()
