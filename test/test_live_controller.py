"""The live diagnostician takes the ``controller`` block: its control impact simulates the PI loops, or none.

The node is fed a simulated Wood-Berry run (its mismatch found) through its
own signal callbacks, in-process; its /diagnostics impact must be the batch
path's (:func:`pmr_ros.service.closing.close_diagnosis`) with the node's
configuration, and differ from what the MPC would have given.
"""

from __future__ import annotations

from dataclasses import replace

import pytest

pytest.importorskip("rclpy")

from numpy.testing import assert_allclose  # noqa: E402

from pmr_ros.config import flatten_parameters, load_config  # noqa: E402
from pmr_ros.contract.layout import diagnosis_from_array  # noqa: E402
from pmr_ros.core.sim.closed_loop import simulate  # noqa: E402
from pmr_ros.nodes.pmr_diagnostician import NODE_NAME, PmrDiagnosticianNode  # noqa: E402
from pmr_ros.ros.convert import signal_message  # noqa: E402
from pmr_ros.ros.parameters import node_parameters, parameter_overrides  # noqa: E402
from pmr_ros.service.closing import close_diagnosis  # noqa: E402

pytestmark = pytest.mark.ros

SAMPLES = 2048
SETTINGS = {
    "diagnostician.window_samples": SAMPLES,
    "diagnostician.update_period_samples": SAMPLES,
    "diagnostician.min_samples": 1024,
    "diagnostician.stale_timeout_s": 600.0,  # never stale: the test feeds the callbacks itself
    "impact.samples": 1024,
}
LUYBEN = {"kind": "pi", "gain": [0.375, -0.075], "integral_time": [8.29, 23.6]}
"""Wood-Berry's BLT tuning (Luyben 1986), as in test_pi_impact."""


@pytest.fixture(scope="module")
def record():
    return simulate(load_config(), samples=SAMPLES)


def _diagnose_live(ros, record, controller: dict | None):
    """The node's last /diagnostics after the whole record went through its r, u, y callbacks."""
    config = load_config(overrides={"controller": controller} if controller else None)
    declared = {p.name for p in node_parameters(NODE_NAME)}
    flat = {k: v for k, v in flatten_parameters(config.parameters).items() if k in declared}
    node = ros.add(
        PmrDiagnosticianNode(context=ros.context, parameter_overrides=parameter_overrides({**flat, **SETTINGS}))
    )
    model = node.config.model
    for k in range(SAMPLES):
        for signal, names in (("r", model.output_names), ("u", model.input_names), ("y", model.output_names)):
            node._on_signal(signal, signal_message(getattr(record, signal)[k], names, k * model.sample_time))
    assert node.wait_idle(300.0) and node.last_published is not None
    diagnosis, info = diagnosis_from_array(node.last_published)
    assert info["status"] == "ok" and info["last_sample"] == SAMPLES - 1
    assert any(e.verdict == "mismatch" for e in diagnosis), "the run's mismatch must be found for an impact"
    return node, diagnosis


def test_a_pi_controller_block_gives_the_pi_loops_impact(ros, record):
    node, live = _diagnose_live(ros, record, LUYBEN)
    assert node.config.controller.kind == "pi" and live.impact is not None
    without = replace(live, impact=None)
    pi = close_diagnosis(without, node.config).diagnosis.impact
    mpc = close_diagnosis(without, replace(node.config, controller=load_config().controller)).diagnosis.impact
    assert pi is not None and mpc is not None
    assert_allclose(live.impact.ise_ratio, pi.ise_ratio, rtol=1e-9)  # the batch path's PI figure, lossless KeyValues
    assert_allclose(live.impact.input_movement_ratio, pi.input_movement_ratio, rtol=1e-9)
    assert abs(pi.ise_ratio - mpc.ise_ratio) > 1e-3 * mpc.ise_ratio  # so the MPC's figure would have failed


def test_an_external_controller_gets_no_impact_and_one_line_why(ros, record):
    node, live = _diagnose_live(ros, record, {"kind": "external"})
    assert live.impact is None and all(e.impact is None for e in live)
    notes = [w for w in node.warnings if "control impact not computed" in w]
    assert len(notes) == 1 and "controller.kind external" in notes[0] and "\n" not in notes[0]
