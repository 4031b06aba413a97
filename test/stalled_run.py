"""A node set whose final verdicts never come, run as a child process by test_node_set_stall.py.

``python test/stalled_run.py CASE DOMAIN`` runs a short lockstep node set in ROS domain DOMAIN and
prints ``NodeSetError: <its line>`` (exit 1) when the run ends in an error, ``finished`` (exit 0)
otherwise.  CASE is ``busy`` (the diagnostician's diagnosis never ends: its worker stays busy),
``publishing`` (the diagnostician's job dies before it publishes anything, so no status comes for
the last window, and a stray producer goes on publishing y after the run's last sample) or
``failing`` (the core's diagnosis raises: the last window's statuses say so).  Before the run's
watch was bounded, the first two spun forever: a busy worker, or messages still reaching the
diagnostician, counted as progress.  Before a failed diagnosis was published, the third waited
for the stall timeout.
"""

from __future__ import annotations

import sys
import time

from pmr_ros.config import load_config
from pmr_ros.contract import windowing
from pmr_ros.contract.topics import topic
from pmr_ros.node_set import NodeSetError, NodeSetOptions, run_node_set
from pmr_ros.nodes.pmr_diagnostician import PmrDiagnosticianNode
from pmr_ros.ros.convert import signal_message
from pmr_ros.ros.messages import message_class, qos_profile

SAMPLES = 300
STALL_TIMEOUT_S = 10.0
VERDICT_TIMEOUT_S = 15.0
STRAY_RATE_HZ = 20.0
"""The stray producer's pace: slow enough that r and u never lag y by diagnostician.max_lag_samples (512)
within the test, which would publish STALE statuses for the last sample and end the run."""


def _never_ending_diagnosis(node: PmrDiagnosticianNode, *args) -> None:
    """Busy until the node is destroyed (its worker shuts down), so the process can still end."""
    while not node.worker._closed:
        time.sleep(0.05)


def _failing_diagnosis(node: PmrDiagnosticianNode, *args) -> None:
    raise RuntimeError("diagnosis failed on purpose (test)")


FAILURE = "RuntimeError: the core failed on purpose (test)"
"""What the ``failing`` case's core raises, as the statuses and the run's line name it."""


def _failing_core(*args, **kwargs) -> None:
    raise RuntimeError(FAILURE.split(": ", 1)[1])


def _stray_producer(config):
    """Builds a node that, once the plant says the run is complete, publishes y for later samples."""

    def build(context, parameters):
        from rclpy.node import Node

        node = Node("stray_producer", context=context, start_parameter_services=False)
        t = topic("measured_output")
        publisher = node.create_publisher(message_class(t), t.name, qos_profile(t.qos))
        model = config.model
        sample = [SAMPLES]
        end = topic("run_complete")
        ended: list = []
        node.create_subscription(message_class(end), end.name, ended.append, qos_profile(end.qos))

        def publish() -> None:
            if not ended:
                return
            values = [0.0] * model.n_outputs
            publisher.publish(signal_message(values, model.output_names, sample[0] * model.sample_time, model.name))
            sample[0] += 1

        node.create_timer(1.0 / STRAY_RATE_HZ, publish)
        return [node]

    return build


def main(case: str, domain: int) -> int:
    """Run the case; print the outcome's one line."""
    config = load_config(overrides={"run": {"samples": SAMPLES}, "pmr": {"segment_length": 64}})
    extra = None
    if case == "busy":
        PmrDiagnosticianNode._diagnose = _never_ending_diagnosis  # type: ignore[method-assign]
    elif case == "failing":
        windowing.diagnose_stretches = _failing_core
    else:
        PmrDiagnosticianNode._diagnose = _failing_diagnosis  # type: ignore[method-assign]
        extra = _stray_producer(config)
    options = NodeSetOptions(
        domain_id=domain,
        private=True,
        stall_timeout_s=STALL_TIMEOUT_S,
        verdict_timeout_s=VERDICT_TIMEOUT_S,
        extra_nodes=extra,
    )
    try:
        run_node_set(config, options)
    except NodeSetError as exc:
        print(f"NodeSetError: {exc}", flush=True)
        return 1
    print("finished", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1], int(sys.argv[2])))
