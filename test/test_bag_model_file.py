"""A bag of a step-response model's run stands alone: the curve file travels inside it.

Known truths: the curves the test writes itself (a .mdl), the verdicts of
the bag diagnosed while the file is where the run read it, and the injected
+15 % on G11.  The file is then deleted (or replaced by other curves) and the
bag diagnosed again: the same verdicts, the same numbers.
"""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pytest
from numpy.testing import assert_allclose

from pmr_ros.bag.reader import open_bag
from pmr_ros.bag.storage import BagError, RunConfig, recorded_topics, typestore
from pmr_ros.bag.writer import BagWriter
from pmr_ros.cli import main
from pmr_ros.config import load_config
from pmr_ros.contract.topics import topic
from pmr_ros.core.sim.closed_loop import simulate
from pmr_ros.core.sim.rational import transfer_function
from pmr_ros.core.sim.step_curve import as_step_response
from pmr_ros.models import CurveSet, write_mdl

SAMPLES = 3000
N = 120
TFS = (("12.8", "40, 14, 1", 1), ("-0.5, 1", "20, 12, 1", 3), ("5, 1", "10, 1", 2), ("-19.4", "14.4, 1", 3))
CONFIG = f"""\
/**:
  ros__parameters:
    system:
      name: step unit
      sample_time: 1.0
      output_names: [x_D, x_B]
      input_names: [reflux, steam]
      model_file: curves/unit.mdl
      delay: [1.0, 3.0, 2.0, 3.0]
      element_type: step_response
    mpc:
      prediction_horizon: 60
      control_horizon: 8
    mismatch:
      gain_pct: [15.0, 0.0, 0.0, 0.0]
    run:
      samples: {SAMPLES}
      scenario: full
    diagnostician:
      min_samples: {SAMPLES}
    impact:
      samples: 0
"""


def _write_mdl(path: Path, scale: float = 1.0) -> None:
    elements = [transfer_function(n, d, delay_samples=delay, sample_time=1.0) for n, d, delay in TFS]
    curves = scale * np.array([[as_step_response(elements[2 * i + k], N).curve for k in range(2)] for i in range(2)])
    path.parent.mkdir(parents=True, exist_ok=True)
    names = (("x_D", "x_B"), ("reflux", "steam"))
    write_mdl(CurveSet(1.0, *names, curves, np.zeros((2, 2), bool), curves[:, :, -1]), path)


def _joint_state(k: int, values: np.ndarray, names: tuple[str, ...]):
    ts = typestore().types
    return ts["sensor_msgs/msg/JointState"](
        header=ts["std_msgs/msg/Header"](stamp=ts["builtin_interfaces/msg/Time"](sec=k, nanosec=0), frame_id="unit"),
        name=list(names),
        position=np.ascontiguousarray(values, dtype=float),
        velocity=np.zeros(0),
        effort=np.zeros(0),
    )


@pytest.fixture(scope="module")
def recorded(tmp_path_factory) -> tuple[Path, Path]:
    """A bag of the step-response model's closed loop (r, u, y, the run configuration) and its params file."""
    folder = tmp_path_factory.mktemp("unit")
    _write_mdl(folder / "curves" / "unit.mdl")
    (folder / "unit.yaml").write_text(CONFIG)
    config = load_config(folder / "unit.yaml")
    record = simulate(config)
    signals = {"setpoint": record.r, "manipulated_input": record.u, "measured_output": record.y}
    names = {"setpoint": ("x_D", "x_B"), "manipulated_input": ("reflux", "steam"), "measured_output": ("x_D", "x_B")}
    topics = {k: t for k, t in recorded_topics().items() if k in (*signals, "run_config")}
    with BagWriter(folder / "bag", topics=topics) as writer:
        writer.write_run_config(RunConfig(config.parameters, source=str(folder / "unit.yaml")), 1)
        for k in range(SAMPLES):
            for key, values in signals.items():
                writer.write_message(topic(key).resolved(), k * 10**9 + 1, _joint_state(k, values[k], names[key]))
    return folder / "bag", folder / "curves" / "unit.mdl"


def _diagnose(bag: Path, out: Path, capsys) -> dict:
    code = main(["diagnose", str(bag), "--json", str(out)])
    assert code == 0, capsys.readouterr().err
    capsys.readouterr()
    return json.loads(out.read_text())["elements"]


def _figures(elements: dict) -> dict:
    """Per element: the verdict, dK % and dalpha % (NaN where the diagnosis gives no number)."""
    numbers = ("gain_mismatch_pct", "tau_mismatch_pct")
    return {
        name: (e["verdict"], *(np.nan if e["parametric"][key] is None else e["parametric"][key] for key in numbers))
        for name, e in elements.items()
    }


def test_the_bag_holds_the_curve_file_and_diagnoses_the_same_without_it(recorded, tmp_path, capsys):
    bag, mdl = recorded
    text = mdl.read_text()
    config = open_bag(bag).run_config()
    assert config is not None and config.model_files == {"system.model_file": text}  # in metadata.yaml
    before = _figures(_diagnose(bag, tmp_path / "before.json", capsys))
    assert before["G11"][0] == "mismatch" and abs(before["G11"][1] - 15.0) < 3.0  # the injected +15 %
    assert all(before[g][0] != "mismatch" for g in ("G12", "G21", "G22"))
    moved = tmp_path / "elsewhere.mdl"
    shutil.move(mdl, moved)  # the file is gone from where the run read it
    try:
        after = _figures(_diagnose(bag, tmp_path / "after.json", capsys))
        _write_mdl(mdl, scale=2.0)  # other curves at the recorded path: the bag's own are used
        changed = _figures(_diagnose(bag, tmp_path / "changed.json", capsys))
    finally:
        shutil.move(moved, mdl)
    for again in (after, changed):
        assert [again[n][0] for n in before] == [before[n][0] for n in before]
        assert_allclose(
            [again[n][1:] for n in before], [before[n][1:] for n in before], rtol=1e-9, atol=1e-9, equal_nan=True
        )


def test_the_run_config_topic_carries_the_curve_file_without_metadata(recorded, tmp_path):
    bag, mdl = recorded
    config = open_bag(bag).run_config()
    assert config is not None
    again = RunConfig.from_text(config.to_text())
    assert again.model_files == config.model_files and again.params == config.params
    shutil.copytree(bag, tmp_path / "bag")
    (tmp_path / "bag" / "metadata.yaml").unlink()  # a recorder killed before closing: the topic alone
    read = open_bag(tmp_path / "bag").run_config()
    assert read is not None and read.model_files == {"system.model_file": mdl.read_text()}


def test_an_embedded_curve_file_that_does_not_read_is_one_line(recorded):
    config = open_bag(recorded[0]).run_config()
    assert config is not None
    broken = RunConfig(config.params, model_files={"system.model_file": "not a model\n"})
    with pytest.raises(BagError, match="the curve file recorded in the bag does not read: .*unit.mdl") as err:
        broken.curve_sets()
    assert "\n" not in str(err.value)
