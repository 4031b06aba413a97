"""The front door: ``import pmr_ros`` stays light; the example of docs/api.md runs and finds the injected mismatch."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import pmr_ros

ROOT = Path(__file__).resolve().parents[1]


def _example() -> str:
    """The first ``python`` block of docs/api.md."""
    text = (ROOT / "docs" / "api.md").read_text(encoding="utf-8")
    blocks = re.findall(r"```python\n(.*?)```", text, flags=re.DOTALL)
    assert blocks, "docs/api.md has no ```python block"
    return blocks[0]


def test_import_pmr_ros_loads_neither_numpy_nor_rclpy():
    code = "import sys, pmr_ros; print('numpy' in sys.modules, 'rclpy' in sys.modules)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True, cwd=ROOT)
    assert out.stdout.split() == ["False", "False"]


def test_every_front_door_name_resolves():
    for name in pmr_ros.__all__:
        assert getattr(pmr_ros, name) is not None
    with pytest.raises(AttributeError):
        pmr_ros.not_a_name  # noqa: B018


@pytest.fixture(scope="module")
def example():
    namespace: dict = {}
    exec(compile(_example(), "docs/api.md", "exec"), namespace)  # the documented example, as written
    return namespace


def test_the_documented_example_finds_the_injected_mismatch(example):
    run, diagnosis = example["run"], example["diagnosis"]
    injected = run.injected
    assert diagnosis.status == "ok" and diagnosis.method == "parametric"
    for element in diagnosis:
        i, k = element.row, element.column
        moved = injected.gain_pct[i, k] or injected.time_constant_pct[i, k] or injected.delay_samples[i, k]
        assert element.verdict == ("mismatch" if moved else "ok"), element.summary()
        result = element.parametric
        # estimated within 2 percentage points of the injected change (the run's 95 % intervals are about +-1)
        np.testing.assert_allclose(result.gain_mismatch_pct, injected.gain_pct[i, k], atol=2.0)
        np.testing.assert_allclose(result.tau_mismatch_pct, injected.time_constant_pct[i, k], atol=2.0)
        assert result.delay_mismatch_samples == injected.delay_samples[i, k]


def test_simulate_returns_the_plant_it_ran_on():
    run = pmr_ros.simulate(samples=300, seed=3, scenario="gain")
    assert run.record.samples == 300 and run.record.u.shape == (300, run.config.model.n_inputs)
    expected = run.config.model.with_mismatch(run.config.mismatch.for_scenario("gain"))
    np.testing.assert_allclose(run.plant.gain, expected.gain, rtol=1e-12)
    np.testing.assert_array_equal(run.injected.time_constant_pct, 0.0)
