"""The four nodes as four processes from their console scripts, with one params file.

Children are always killed; timeouts are generous because the machine may be busy.
"""

from __future__ import annotations

import os
import signal
import subprocess
from pathlib import Path

import pytest
import rclpy  # noqa: F401  # the ROS 2 wheels are part of the set-up (test.sh): missing is an error, not a skip
from ros_fixtures import console_script, spin_until  # noqa: E402

from pmr_ros.config import config_dir, load_config  # noqa: E402
from pmr_ros.contract.layout import diagnosis_from_array  # noqa: E402
from pmr_ros.contract.proposal import close_diagnosis  # noqa: E402
from pmr_ros.contract.topics import topic  # noqa: E402
from pmr_ros.core.closed_loop import simulate  # noqa: E402
from pmr_ros.core.diagnosis import diagnose  # noqa: E402
from pmr_ros.core.results import compare_diagnoses  # noqa: E402
from pmr_ros.ros.topics import message_class, qos_profile  # noqa: E402

pytestmark = pytest.mark.ros

SAMPLES = 3000
NODES = ("pmr_diagnostician", "mpc_controller", "prbs_setpoint", "wood_berry_plant")


def _run_file(tmp_path: Path) -> Path:
    path = tmp_path / "run.yaml"
    path.write_text(
        "/**:\n  ros__parameters:\n"
        f"    run:\n      samples: {SAMPLES}\n"
        f"    diagnostician:\n      window_samples: {SAMPLES}\n      update_period_samples: {SAMPLES}\n      "
        f"min_samples: {SAMPLES}\n"
    )
    return path


def _stop(proc: subprocess.Popen, how: int) -> None:
    if proc.poll() is None:
        proc.send_signal(how)
    try:
        proc.wait(timeout=15)
    except subprocess.TimeoutExpired:
        proc.kill()
        proc.wait(timeout=5)


def test_four_processes_give_the_batch_verdicts_and_stop_cleanly(tmp_path, ros_context):
    from rclpy.executors import SingleThreadedExecutor

    run_file = _run_file(tmp_path)
    system_file = config_dir() / "wood_berry.yaml"
    logs, procs = {}, {}
    listener = rclpy.create_node("test_listener", context=ros_context)
    t = topic("diagnostics")
    final = []

    def on_diagnostics(msg):
        diagnosis, info = diagnosis_from_array(msg, "pmr_diagnostician")
        if info.get("last_sample") == SAMPLES - 1:
            final.append((diagnosis, info))

    listener.create_subscription(message_class(t), t.name, on_diagnostics, qos_profile(t.qos))
    executor = SingleThreadedExecutor(context=ros_context)
    executor.add_node(listener)
    try:
        for name in NODES:
            logs[name] = open(tmp_path / f"{name}.log", "w+")  # noqa: SIM115 - closed in finally
            procs[name] = subprocess.Popen(
                [console_script(name), "--ros-args", "--params-file", str(system_file), "--params-file", str(run_file)],
                stdout=logs[name],
                stderr=subprocess.STDOUT,
                env=dict(os.environ),
            )
        assert spin_until(executor, lambda: bool(final) or any(p.poll() is not None for p in procs.values()), 120.0), (
            "no final verdicts in 120 s"
        )
        assert final, {n: (tmp_path / f"{n}.log").read_text()[-2000:] for n in NODES}
        diagnosis, info = final[0]
        config = load_config(overrides={"run": {"samples": SAMPLES}})
        batch = simulate(config)
        expected = diagnose(batch.r, batch.u, batch.y, model=config.model, pmr=config.pmr, parametric=config.parametric)
        expected = close_diagnosis(expected, config).diagnosis  # the diagnostician adds the control impact
        assert diagnosis.status == expected.status == "ok"
        # other processes: verdicts exact, numbers to the tolerance of core.results.compare_diagnoses
        assert compare_diagnoses(diagnosis.to_dict()["elements"], expected.to_dict()["elements"]) == []
        assert info["first_sample"] == 0 and info["window_samples"] == SAMPLES
        # Ctrl-C for two, SIGTERM for the other two: all exit 0, without a traceback.
        for name, how in zip(NODES, (signal.SIGINT, signal.SIGTERM, signal.SIGINT, signal.SIGTERM), strict=True):
            _stop(procs[name], how)
            text = (tmp_path / f"{name}.log").read_text()
            assert procs[name].returncode == 0, (name, text[-2000:])
            assert "Traceback" not in text, (name, text)
    finally:
        for proc in procs.values():
            if proc.poll() is None:
                proc.kill()
                proc.wait(timeout=5)
        for handle in logs.values():
            handle.close()
        executor.shutdown(timeout_sec=1.0)
        listener.destroy_node()


@pytest.mark.parametrize(
    ("arguments", "words"),
    [
        (["-p", "pmr.segment_length:=0"], "pmr.segment_length = 0"),
        (["-p", "system.gain:=[1.0, 2.0]"], "system.gain = [1.0, 2.0]: needs 4 entries"),
        (["-p", "diagnostician.windw_samples:=10"], "unknown parameter; did you mean diagnostician.window_samples?"),
        (["--params-file", "/nonexistent/params.yaml"], "error"),
        ([], "system: missing"),
    ],
)
def test_a_node_with_bad_parameters_exits_with_one_clear_line(ros_domain, arguments, words):
    system = [] if not arguments else ["--params-file", str(config_dir() / "wood_berry.yaml")]
    proc = subprocess.run(
        [console_script("pmr_diagnostician"), "--ros-args", *system, *arguments],
        capture_output=True,
        text=True,
        timeout=60,
        env=dict(os.environ),
    )
    assert proc.returncode == 2, proc.stderr
    assert words in proc.stderr
    assert "Traceback" not in proc.stderr + proc.stdout
