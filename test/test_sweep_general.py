"""The time-constant sweep on a model that holds a tf element: it sweeps a FOPTD element, refuses to sweep the tf.

Known truths: the mismatch scenario injected (the tf element scaled as a
whole by ``Element.scaled``), the swept time constant, and the one-line
refusal naming why a tf element has no time constant to sweep.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from numpy.testing import assert_allclose

from pmr_ros.cli import main
from pmr_ros.config import load_config
from pmr_ros.sweep.analysis import summarize
from pmr_ros.sweep.execute import PointTask, run_point
from pmr_ros.sweep.plan import PlanError, SweepPlan, element_index
from pmr_ros.sweep.tuning import STABILITY_LIMIT

MIXED = """\
/**:
  ros__parameters:
    system:
      name: mixed
      sample_time: 1.0
      output_names: [x_D, x_B]
      input_names: [reflux, steam]
      element_type: [foptd, tf, foptd, foptd]
      gain: [12.8, 0.0, 6.6, -19.4]
      time_constant: [16.7, 0.0, 10.9, 14.4]
      numerator: ["", "-18.9", "", ""]
      denominator: ["", "100, 25, 1", "", ""]
      delay: [1.0, 3.0, 7.0, 3.0]
    mismatch:
      gain_pct: [0.0, 15.0, 0.0, 0.0]
      time_constant_pct: [0.0, 12.0, 0.0, 0.0]
      delay_samples: [0, 1, 0, 0]
"""


@pytest.fixture(scope="module")
def mixed(tmp_path_factory) -> Path:
    path = tmp_path_factory.mktemp("sweep") / "mixed.yaml"
    path.write_text(MIXED)
    return path


def test_a_tf_element_is_refused_as_the_swept_one_in_one_line(mixed, tmp_path, capsys):
    model = load_config(mixed).model
    assert element_index(model, "G21") == (1, 0)
    with pytest.raises(PlanError, match=r"G12 is tf: it has no single time constant to sweep .*\(G11, G21, G22\)"):
        element_index(model, "G12")
    code = main(["sweep", "--config", str(mixed), "--out", str(tmp_path / "o"), "--elements", "G12", "--quiet"])
    err = capsys.readouterr().err
    assert code == 2 and err.count("\n") == 1 and "G12 is tf: it has no single time constant" in err, err


def test_a_sweep_of_a_foptd_element_beside_a_tf_element_scales_the_tf_and_diagnoses_every_element(mixed):
    config = load_config(mixed)
    plan = SweepPlan(elements=("G21",), nu=(2.0,), seeds=(1,), samples=3000, scenarios=("full",))
    (point,) = plan.points(config.model)
    task = PointTask(point, tuple(plan.runs()), ("classic", "parametric"), plan.samples, plan.scenarios)
    rows = run_point(config, task)
    assert {r["element"] for r in rows} == {"G11", "G12", "G21", "G22"} and len(rows) == 8
    assert all(r["time_constant_swept"] == pytest.approx(21.8) for r in rows)
    assert all(r["mpc_failures"] == 0 and r["loop_spectral_radius"] < STABILITY_LIMIT for r in rows)
    g12 = {r["method"]: r for r in rows if r["element"] == "G12"}
    assert g12["classic"]["tau_index"] is None  # no time-constant index for a tf element
    fit = g12["parametric"]
    # the plant's G12 is 1.15 G12hat(1.12 s) e^{-s}: its gain, dynamics and delay change found
    assert abs(fit["gain_mismatch_pct"] - 15.0) < 3.0 and abs(fit["tau_mismatch_pct"] - 12.0) < 5.0
    assert fit["delay_mismatch_samples"] == 1 and fit["verdict"] == "mismatch"
    summary = {(p.method, p.element): p for p in summarize(rows, tau_threshold=1.0)}
    assert summary["classic", "G12"].tau_wrong == 1  # not judged: counted as not right, not as a crash
    assert summary["parametric", "G12"].gain_wrong == summary["parametric", "G12"].tau_wrong == 0
    assert_allclose(summary["parametric", "G12"].gain_median, 1 + fit["gain_mismatch_pct"] / 100, rtol=1e-12)
    assert np.isfinite(summary["classic", "G12"].gain_median)
