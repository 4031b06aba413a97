"""The nodes as processes from their console scripts: verdicts, recorders, namespaces, restarts, signals.

Each test owns its processes (the ``ros``/``children`` fixtures kill what is left); deadlines are
generous because the machine may be busy, and every wait is on a condition, never a fixed sleep.
"""

from __future__ import annotations

import json
import os
import re
import signal
import subprocess
import time
from pathlib import Path

import pytest
import rclpy  # noqa: F401  # the ROS 2 wheels are part of the set-up (test.sh): missing is an error, not a skip
from ros_fixtures import console_script  # noqa: E402
from shipped import with_impact_samples  # noqa: E402

from pmr_ros.bag.reader import open_bag  # noqa: E402
from pmr_ros.config import config_dir, load_config  # noqa: E402
from pmr_ros.contract.layout import diagnosis_from_array  # noqa: E402
from pmr_ros.contract.topics import topic  # noqa: E402
from pmr_ros.core.pmr.diagnosis import diagnose  # noqa: E402
from pmr_ros.core.results import compare_diagnoses  # noqa: E402
from pmr_ros.core.results.codec import diagnosis_to_json
from pmr_ros.core.sim.closed_loop import simulate  # noqa: E402
from pmr_ros.ros.messages import message_class, qos_profile  # noqa: E402
from pmr_ros.service.closing import close_diagnosis  # noqa: E402

pytestmark = pytest.mark.ros

NODES = ("pmr_diagnostician", "mpc_controller", "prbs_setpoint", "wood_berry_plant")
SIGNALS = ("setpoint", "manipulated_input", "measured_output", "clock")


def _params_file(tmp_path: Path, samples: int, name: str = "run.yaml", **blocks: dict) -> Path:
    diagnostician = {"window_samples": samples, "update_period_samples": samples, "min_samples": samples}
    tree = {"run": {"samples": samples}, "diagnostician": diagnostician}
    for block, values in blocks.items():
        tree.setdefault(block, {}).update(values)
    lines = ["/**:", "  ros__parameters:"]
    for block, values in tree.items():
        lines.append(f"    {block}:")
        lines.extend(f"      {key}: {json.dumps(value)}" for key, value in values.items())
    path = tmp_path / name
    path.write_text("\n".join(lines) + "\n")
    return path


def _start_nodes(ros, tmp_path: Path, run_file: Path, names=NODES) -> dict[str, subprocess.Popen]:
    system = config_dir() / "wood_berry.yaml"
    return {
        name: ros.start(
            [console_script(name), "--ros-args", "--params-file", str(system), "--params-file", str(run_file)],
            tmp_path / f"{name}.log",
        )
        for name in names
    }


class _Watcher:
    """Follows the plant's samples on /clock and keeps the final /diagnostics of a run.

    /clock, not y: a subscriber of y that reports no progress is one the plant waits for, up to
    plant.CONSUMER_DISCOVERY_S (15 s) at each start, before it names it and goes on.  The plant publishes
    the clock k Ts just before y(k), once it has applied u(k - 1): sample k on /clock tells the same.
    """

    def __init__(self, ros, last_sample: int) -> None:
        self.last_sample, self.newest_sample, self.final = last_sample, -1, None
        node = ros.create_node("test_watcher")
        for key, callback in (("clock", self._on_clock), ("diagnostics", self._on_diagnostics)):
            t = topic(key)
            node.create_subscription(message_class(t), t.name, callback, qos_profile(t.qos))

    def _on_clock(self, msg) -> None:
        self.newest_sample = max(self.newest_sample, int(round(read_signal_or_clock(msg))))

    def _on_diagnostics(self, msg) -> None:
        diagnosis, info = diagnosis_from_array(msg, "pmr_diagnostician")
        if info.get("last_sample") == self.last_sample:
            self.final = (diagnosis, info)


def _wait_subscribed(ros, topic_name: str, count: int) -> None:
    """Wait until ``count`` nodes subscribe to ``topic_name`` (recorders started before the set they record)."""
    probe = ros.create_node(f"probe_{len(ros.nodes)}")
    assert ros.spin_until(lambda: probe.count_subscribers(topic_name) >= count, 120.0), f"no subscriber of {topic_name}"


def _logs(tmp_path: Path, names=NODES) -> dict[str, str]:
    return {n: (tmp_path / f"{n}.log").read_text()[-3000:] for n in names if (tmp_path / f"{n}.log").exists()}


def _stop(ros, proc: subprocess.Popen, how: int) -> int:
    proc.send_signal(how)
    assert ros.spin_until(lambda: proc.poll() is not None, 60.0), f"no exit within 60 s of {how!r}"
    return proc.returncode


def _contiguous(bag, name: str) -> tuple[int, int]:
    """First and last sample of a recorded signal topic, checking that no sample between is missing."""
    stamps = [int(round(read_signal_or_clock(bag.decode(m)))) for m in bag.messages({name})]
    assert stamps, f"nothing recorded on {name}"
    assert stamps == list(range(stamps[0], stamps[-1] + 1)), f"{name}: samples missing or repeated"
    return stamps[0], stamps[-1]


def read_signal_or_clock(msg) -> float:
    stamp = msg.clock if hasattr(msg, "clock") else msg.header.stamp
    return stamp.sec + stamp.nanosec * 1e-9


def test_four_processes_give_the_batch_verdicts_and_loaded_recorders_lose_nothing(ros, tmp_path):
    # 2,000 samples (was 3,000; the run's latency-bound hops cost ~25 ms a sample under load): the batch
    # diagnosis of 2,000 samples is "ok" with every verdict decided, as at 3,000 (measured)
    samples = 2000
    # the plant starts once all four subscribers of y are there: controller, diagnostician, two recorders;
    # impact simulations of 1,024 samples, not 4,096 (the diagnostician's and the batch's are compared below)
    impact = {"samples": 1024}
    run_file = _params_file(tmp_path, samples, simulation={"wait_for_subscribers": 4}, impact=impact)
    # two recorders of the live set, stopped half-way, one by Ctrl-C and one by SIGTERM
    recorders = {
        how: ros.start(
            [console_script("pmr-ros"), "record", str(tmp_path / f"bag_{how.name}"), "--no-parameters"],
            tmp_path / f"record_{how.name}.log",
        )
        for how in (signal.SIGINT, signal.SIGTERM)
    }
    _wait_subscribed(ros, topic("measured_output").resolved(), 2)
    watcher = _Watcher(ros, samples - 1)
    procs = _start_nodes(ros, tmp_path, run_file)
    stopped_at = {}
    for how, at in ((signal.SIGINT, 600), (signal.SIGTERM, 1200)):
        assert ros.spin_until(lambda at=at: watcher.newest_sample >= at, 300.0), (at, _logs(tmp_path))
        stopped_at[how] = watcher.newest_sample
        assert _stop(ros, recorders[how], how) == 0
    assert ros.spin_until(lambda: watcher.final is not None, 300.0), _logs(tmp_path)
    diagnosis, info = watcher.final
    config = load_config(overrides={"run": {"samples": samples}, "impact": impact})
    batch = simulate(config)
    expected = diagnose(batch.r, batch.u, batch.y, model=config.model, pmr=config.pmr, parametric=config.parametric)
    expected = close_diagnosis(expected, config).diagnosis  # the diagnostician adds the control impact
    assert diagnosis.status == expected.status == "ok"
    assert diagnosis.impact is not None  # compared with the rest
    # other processes: verdicts exact, numbers to the tolerance of core.results.compare_diagnoses
    assert compare_diagnoses(diagnosis_to_json(diagnosis)["elements"], diagnosis_to_json(expected)["elements"]) == []
    assert info["first_sample"] == 0 and info["window_samples"] == samples
    for how, at in stopped_at.items():
        text = (tmp_path / f"record_{how.name}.log").read_text()
        assert "Traceback" not in text, text
        bag = open_bag(tmp_path / f"bag_{how.name}")
        assert bag.complete
        ranges = {key: _contiguous(bag, topic(key).resolved()) for key in SIGNALS}
        # from sample 0 to past the moment it was stopped, without a hole, on every topic alike
        assert all(first == 0 and last >= at for first, last in ranges.values()), (how, ranges, at)
    # Ctrl-C for two nodes, SIGTERM for the other two: all exit 0, without a traceback.
    for name, how in zip(NODES, (signal.SIGINT, signal.SIGTERM, signal.SIGINT, signal.SIGTERM), strict=True):
        assert _stop(ros, procs[name], how) == 0, _logs(tmp_path)[name]
        assert "Traceback" not in (tmp_path / f"{name}.log").read_text()


def test_a_plant_killed_and_restarted_resumes_the_run(ros, tmp_path):
    # killed at 1000 or later: 1000 samples still to run after the restart (was 3,000 and 1,500; the classic
    # diagnosis of the 2,000 samples, and of the 1,000 after the break, is "ok" as at 3,000: measured)
    samples = 2000
    pmr = {"method": "classic", "segment_length": 128}
    # the restarted plant learns where the run is from the controller's newest input; under load that input
    # reached it only after the default 3 s settle and the 0.5 s resume settle (seen once in 6 runs: it started
    # over from sample 0).  It now waits for it while the diagnostician reports samples taken (RESUME_WAIT_S).
    diagnostician = {"update_period_samples": 1000, "min_samples": 1000}
    run_file = _params_file(tmp_path, samples, pmr=pmr, diagnostician=diagnostician)
    watcher = _Watcher(ros, samples - 1)
    procs = _start_nodes(ros, tmp_path, run_file)
    assert ros.spin_until(lambda: watcher.newest_sample >= 1000, 300.0), _logs(tmp_path)
    seen = watcher.newest_sample  # sample seen was published, so the controller had answered u(seen - 1)
    procs["wood_berry_plant"].send_signal(signal.SIGKILL)  # a crash: no clean-up at all
    procs["wood_berry_plant"].wait(timeout=30)
    (tmp_path / "wood_berry_plant.log").rename(tmp_path / "crashed_plant.log")
    again = _start_nodes(ros, tmp_path, run_file, names=("wood_berry_plant",))["wood_berry_plant"]
    assert ros.spin_until(lambda: watcher.final is not None, 300.0), _logs(tmp_path)
    text = (tmp_path / "wood_berry_plant.log").read_text()
    resumed = re.search(r"resuming the run after sample (\d+)", text)
    assert resumed, text
    diagnosis, info = watcher.final
    # the restarted plant resumes after the last sample the controller answered: u(seen - 1) or a later one
    after = int(resumed.group(1))
    assert after >= seen - 1, (seen, text)
    # every loss is counted: the sample left out, and what the killed writer took with it before the
    # diagnostician had it (under load: y(after), which the controller had and answered), just before it
    lost = _lost_samples((tmp_path / "pmr_diagnostician.log").read_text(), load_config().model.sample_time)
    assert lost and lost == set(range(min(lost), after + 2)), (after, lost)
    # the window (default 16384) holds both stretches around the break, less the samples lost
    assert diagnosis.status == "ok" and info["first_sample"] == 0, info
    assert info["window_samples"] == samples - len(lost), (info, lost)
    assert again.poll() is None and "Traceback" not in text


def _lost_samples(log: str, sample_time: float) -> set[int]:
    """The samples a diagnostician's log reports lost, on any signal."""
    lost: set[int] = set()
    for first, last in re.findall(r"sample\(s\) lost, stamps ([-+.\de]+)\.\.([-+.\de]+) s", log):
        lost.update(range(round(float(first) / sample_time), round(float(last) / sample_time) + 1))
    return lost


def test_lost_samples_are_read_from_a_diagnostician_log():
    log = (
        "[WARN] [1.5] [pmr_diagnostician]: r on /pmr/setpoint: 1 sample(s) lost, stamps 1501..1501 s (1 lost)\n"
        "[WARN] [1.6] [pmr_diagnostician]: y on /pmr/measured_output: 2 sample(s) lost, stamps 1500..1501 s (2 lost)\n"
    )
    assert _lost_samples(log, 1.0) == {1500, 1501}
    assert _lost_samples(log.replace("1500..", "3000..").replace("1501", "3002"), 2.0) == {1500, 1501}


def _run(ros, tmp_path: Path, name: str, *arguments: str) -> subprocess.Popen:
    argv = [console_script("pmr-ros"), "run", "--visible", "--json", str(tmp_path / f"{name}.json"), *arguments]
    return ros.start(argv, tmp_path / f"{name}.log")


def test_two_node_sets_in_one_domain_under_their_namespaces_each_report_their_own_verdicts(ros, tmp_path):
    samples = 3000  # was 4,000: the batch diagnosis of seeds 1 and 2 is "ok" at 3,000 too (measured)
    bag = tmp_path / "column_a_bag"
    recorder = ros.start(
        [console_script("pmr-ros"), "record", str(bag), "--namespace", "column_a", "--no-parameters"],
        tmp_path / "record.log",
    )
    _wait_subscribed(ros, topic("measured_output").resolved("/column_a"), 1)
    # impact simulations of 1,024 samples, not 4,096 (only their presence is checked here); column_a's plant waits
    # for its recorder too (3 subscribers of y), however long DDS takes to discover it
    impact = ("--config", str(with_impact_samples(tmp_path, 1024)))
    options = {"column_a": (*impact, "--wait-for-subscribers", "3"), "column_b": impact}
    runs = {
        name: _run(
            ros, tmp_path, name, "--namespace", name, "--seed", str(seed), "--samples", str(samples), *options[name]
        )
        for name, seed in (("column_a", 1), ("column_b", 2))
    }
    assert ros.spin_until(lambda: all(p.poll() is not None for p in runs.values()), 600.0)
    for (name, proc), seed in zip(runs.items(), (1, 2), strict=True):
        text = (tmp_path / f"{name}.log").read_text()
        assert proc.returncode == 0, text
        report = json.loads((tmp_path / f"{name}.json").read_text())
        config = load_config(overrides={"run": {"samples": samples, "seed": seed}})
        batch = simulate(config)
        expected = diagnosis_to_json(
            diagnose(batch.r, batch.u, batch.y, model=config.model, pmr=config.pmr, parametric=config.parametric)
        )["elements"]
        # the run adds the control impact of its mismatch verdicts; the batch diagnosis has none
        assert all(e["impact"] is not None for e in report["elements"].values() if e["verdict"] == "mismatch")
        reported = {n: {k: v for k, v in e.items() if k != "impact"} for n, e in report["elements"].items()}
        assert (
            compare_diagnoses(reported, {n: {k: v for k, v in e.items() if k != "impact"} for n, e in expected.items()})
            == []
        ), name
        assert report["node_set"]["diagnostician_warnings"] == []
    # the recorder of column_a took that set alone, every sample of it
    assert _stop(ros, recorder, signal.SIGINT) == 0
    recorded = open_bag(bag)
    assert not any(name.startswith("/column_b") or name.startswith("/pmr/") for name in recorded.topics)
    for key in SIGNALS:
        assert _contiguous(recorded, topic(key).resolved("/column_a")) == (0, samples - 1), key


def test_two_node_sets_without_namespaces_are_detected_not_merged(ros, tmp_path):
    # both plants wait until both sets subscribe (4 subscribers of y), so the sets surely overlap
    system = (config_dir() / "wood_berry.yaml").read_text()
    config = tmp_path / "together.yaml"
    config.write_text(system + "    simulation:\n      wait_for_subscribers: 4\n")
    runs = {
        name: _run(ros, tmp_path, name, "--config", str(config), "--seed", str(seed), "--samples", "4000")
        for name, seed in (("first", 1), ("second", 2))
    }
    assert ros.spin_until(lambda: all(p.poll() is not None for p in runs.values()), 600.0)
    for name, proc in runs.items():
        text = (tmp_path / f"{name}.log").read_text()
        assert proc.returncode == 1, text
        assert "conflict" in text and "publishers on" in text and "Traceback" not in text, text
        assert not (tmp_path / f"{name}.json").exists()  # no report of a merged, wrong verdict


def _loaded(pid: int, library: str) -> bool:
    """Whether process ``pid`` has mapped a shared library whose path contains ``library``."""
    try:
        return library in Path(f"/proc/{pid}/maps").read_text()
    except OSError:  # gone already
        return True


START_PHASES = {
    "importing numpy": lambda proc, started: _loaded(proc.pid, "_multiarray_umath"),
    "importing rclpy": lambda proc, started: _loaded(proc.pid, "_rclpy_pybind11"),
    "building the node": lambda proc, started: time.monotonic() - started > 2.5,
}
"""Moments of the start-up, told by what the process has loaded (any Python code of pmr_ros runs by then)."""


@pytest.mark.parametrize("phase", sorted(START_PHASES))
def test_ctrl_c_at_any_moment_of_the_start_exits_without_a_traceback(ros_domain, children, phase):
    system = str(config_dir() / "wood_berry.yaml")
    commands = {
        "pmr_diagnostician": ([console_script("pmr_diagnostician"), "--ros-args", "--params-file", system], 0),
        "wood_berry_plant": ([console_script("wood_berry_plant"), "--ros-args", "--params-file", system], 0),
        "pmr-ros": ([console_script("pmr-ros"), "run", "--samples", "100000"], 130),
    }
    for name, (argv, code) in commands.items():
        started = time.monotonic()
        proc = subprocess.Popen(argv, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
        children.append(proc)
        while not START_PHASES[phase](proc, started) and time.monotonic() - started < 60:
            time.sleep(0.001)
        proc.send_signal(signal.SIGINT)
        out, _ = proc.communicate(timeout=60)
        assert proc.returncode == code, (name, out)
        assert "Traceback" not in out and "Error" not in out, (name, out)


def test_a_node_with_bad_parameters_is_refused_in_one_line(ros_domain):
    cases = [
        (["-p", "pmr.segment_length:=0"], "pmr.segment_length = 0"),
        (["-p", "system.gain:=[1.0, 2.0]"], "system.gain = [1.0, 2.0]: needs 4 entries"),
        (["-p", "diagnostician.windw_samples:=10"], "unknown parameter; did you mean diagnostician.window_samples?"),
        (["--params-file", "/nonexistent/params.yaml"], "error"),
        ([], "system: missing"),
    ]
    for arguments, words in cases:
        system = [] if not arguments else ["--params-file", str(config_dir() / "wood_berry.yaml")]
        proc = subprocess.run(
            [console_script("pmr_diagnostician"), "--ros-args", *system, *arguments],
            capture_output=True,
            text=True,
            timeout=120,
            env=dict(os.environ),
        )
        assert proc.returncode == 2, proc.stderr
        assert words in proc.stderr
        assert "Traceback" not in proc.stderr + proc.stdout
