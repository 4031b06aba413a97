"""``pmr_bag_recorder``: records every topic of the contract from a live graph into a rosbag2 bag.

It subscribes to each topic of ``msg_defs/topics.yaml`` with the contract's
QoS in *raw* mode, so the CDR bytes from the wire go to the bag untouched
(:class:`pmr_ros.bag.writer.BagWriter`), stamped with their receive time as
``ros2 bag record`` does.  A wall-clock timer flushes the bag every
``flush_period_s``; SIGINT/SIGTERM close it (summary and metadata.yaml), and a
SIGKILL loses at most what arrived since the last flush.

The run's configuration goes into the bag from, in this order: a params file
given to the recorder, the latched ``/pmr/run_config`` topic (e.g. from a
replay), or the parameters of the live ``pmr_diagnostician`` fetched through
its parameter services.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from contextlib import suppress
from typing import TYPE_CHECKING, Any

from rclpy.clock import Clock, ClockType
from rclpy.node import Node

from ..bag.storage import RUN_CONFIG_KEY, RunConfig, typestore
from ..bag.writer import DEFAULT_FLUSH_PERIOD_S, BagWriter
from ..config import nested
from ..contract.layout import diagnosis_from_array
from ..ros.flow import ProgressReporter, cdr_stamp_ns
from ..ros.messages import message_class, qos_profile
from ..ros.parameters import node_parameters, plain_value

if TYPE_CHECKING:
    from rclpy.parameter_client import AsyncParameterClient
    from rclpy.task import Future

NODE_NAME = "pmr_bag_recorder"
PARAMETER_SOURCE_NODE = "pmr_diagnostician"
"""Node whose parameters are recorded when no configuration is given (it holds them all)."""


class BagRecorderNode(Node):
    """Writes the contract's topics to ``writer`` as they arrive.

    Parameters
    ----------
    writer : BagWriter
        An open bag; the node closes it in :meth:`close`.
    run_config : RunConfig, optional
        Recorded at once; otherwise taken from the wire or a live node.
    parameter_source : str or None
        Node to fetch the parameters from when no configuration arrives;
        None: do not ask.
    flush_period_s : float
        Wall time between flushes [s].
    expected_samples : int, optional
        A run of this many samples is recorded: :attr:`done` tells when all
        of it, its final verdicts included, is in the bag.
    **kwargs
        For :class:`rclpy.node.Node` (``context``).

    Attributes
    ----------
    counts : dict
        Topic name -> messages written.
    """

    def __init__(
        self,
        writer: BagWriter,
        *,
        run_config: RunConfig | None = None,
        parameter_source: str | None = PARAMETER_SOURCE_NODE,
        flush_period_s: float = DEFAULT_FLUSH_PERIOD_S,
        expected_samples: int | None = None,
        node_name: str = NODE_NAME,
        **kwargs,
    ) -> None:
        super().__init__(node_name, start_parameter_services=False, **kwargs)
        self.writer = writer
        self.counts = dict.fromkeys((t.name for t in writer.topics.values()), 0)
        self._config_topic = writer.topics[RUN_CONFIG_KEY].name
        self.has_config = False
        self._closing = False
        self.expected_samples = expected_samples
        self._final_seen = False
        self._final_has_verdict = False
        self._signal_topics = [
            writer.topics[k].name for k in ("setpoint", "manipulated_input", "measured_output", "clock")
        ]
        self._diagnostics_topic = writer.topics["diagnostics"].name
        self._estimates_topic = writer.topics["estimates"].name
        # a lockstep consumer: the plant or a bag player never runs more than max_samples_ahead ahead of it
        self.progress = ProgressReporter(self, self._signal_topics)
        self.last_message_at = time.monotonic()
        if run_config is not None:
            writer.write_run_config(run_config, time.time_ns())
            self.counts[self._config_topic] += 1
            self.has_config = True
        self._subs = []
        for t in writer.topics.values():
            self._subs.append(
                self.create_subscription(
                    message_class(t), t.name, self._writer_of(t.name), qos_profile(t.qos), raw=True
                )
            )
        wall = Clock(clock_type=ClockType.STEADY_TIME)
        self._flush_timer = self.create_timer(max(flush_period_s, 0.01), writer.flush, clock=wall)
        self._parameter_client: AsyncParameterClient | None = None
        self._parameter_future: Future | None = None
        if parameter_source and not self.has_config:
            from rclpy.parameter_client import AsyncParameterClient

            self._parameter_source = parameter_source
            self._parameter_client = AsyncParameterClient(self, parameter_source)
            self._parameter_timer = self.create_timer(0.2, self._ask_parameters, clock=wall)

    def _writer_of(self, name: str):
        def on_message(data: bytes) -> None:
            if self._closing:
                return
            if name == self._config_topic:
                if self.has_config:
                    return  # one configuration per bag: the first wins
                self._take_config(data)
                return
            self.writer.write_raw(name, time.time_ns(), data)
            self.counts[name] += 1
            self.last_message_at = time.monotonic()
            if name in self._signal_topics:
                self._took(name, data)
            if name == self._diagnostics_topic and self.expected_samples is not None:
                self._note_final(data, self.expected_samples - 1)

        return on_message

    def _took(self, name: str, data: bytes) -> None:
        try:
            self.progress.took(name, cdr_stamp_ns(data))
        except ValueError as exc:  # recorded as it came; a message without a stamp cannot count as progress
            self.get_logger().warning(f"{name}: {exc}", throttle_duration_sec=5.0)

    def stop_reporting(self) -> None:
        """Report no further progress, so producers stop ``max_samples_ahead`` samples on.

        What is on its way can then still be taken (:func:`drain`) before the bag is closed.
        """
        self.progress.held = True

    def _note_final(self, data: bytes, last_sample: int) -> None:
        diagnosis, info = diagnosis_from_array(typestore().deserialize_cdr(data, "diagnostic_msgs/msg/DiagnosticArray"))
        if info.get("last_sample") == last_sample:
            self._final_seen = True
            self._final_has_verdict = diagnosis.status == "ok"

    @property
    def failure(self) -> str | None:
        """Why the bag cannot be written any more (a full disk), one line; None while it can."""
        return self.writer.failure

    @property
    def done(self) -> bool:
        """A run of ``expected_samples`` is wholly recorded (always True without one)."""
        if self.expected_samples is None:
            return True
        signals = all(self.counts[name] >= self.expected_samples for name in self._signal_topics)
        estimates = self.counts[self._estimates_topic] >= 1 or not self._final_has_verdict
        return signals and self._final_seen and estimates

    def _take_config(self, data: bytes) -> None:
        text = typestore().deserialize_cdr(data, "std_msgs/msg/String").data
        try:
            config = RunConfig.from_text(text)
        except Exception as exc:  # a foreign string on the topic: record it as is, without custom_data
            self.get_logger().warning(f"{self._config_topic}: not a pmr_ros run configuration ({exc}); recorded as is")
            self.writer.write_raw(self._config_topic, time.time_ns(), data)
        else:
            self.writer.write_run_config(config, time.time_ns())
        self.counts[self._config_topic] += 1
        self.has_config = True

    def _ask_parameters(self) -> None:
        if self.has_config:
            self._parameter_timer.cancel()
            return
        if self._parameter_future is not None:
            if self._parameter_future.done():
                self._parameter_timer.cancel()
                self._store_parameters(self._parameter_future.result())
            return
        if self._parameter_client is None:  # the timer exists only with a client
            return
        if self._parameter_client.services_are_ready():
            self._parameter_future = self._parameter_client.get_parameters(self._parameter_names())

    def _parameter_names(self) -> list[str]:
        return [p.name for p in node_parameters(PARAMETER_SOURCE_NODE)]

    def _store_parameters(self, response: Any) -> None:
        from rclpy.parameter import parameter_value_to_python

        if self.has_config or response is None:
            return
        values = [plain_value(parameter_value_to_python(v)) for v in response.values]
        flat = {n: v for n, v in zip(self._parameter_names(), values, strict=False) if v is not None}
        self.writer.write_run_config(
            RunConfig(nested(flat), source=f"parameters of /{self._parameter_source}"), time.time_ns()
        )
        self.counts[self._config_topic] += 1
        self.has_config = True
        self.get_logger().info("recorded the run configuration from the live diagnostician's parameters")

    def close(self) -> None:
        """Close the bag (summary, metadata.yaml); the node stops writing.

        Safe after the node was destroyed (the node set destroys its nodes first).
        """
        self._closing = True
        with suppress(Exception):  # the timers are gone when the node was destroyed
            self._flush_timer.cancel()
        with suppress(Exception):
            self.progress.destroy()
        self.writer.close()


DRAIN_QUIET_S = 0.3
"""A stopping recorder takes messages until none came for this long [s of wall time] ..."""
DRAIN_LIMIT_S = 10.0
"""... or for at most this long [s of wall time]."""


def drain(recorder: BagRecorderNode, spin: Callable[[float], None]) -> None:
    """Take what is still on its way to a stopping recorder before its bag is closed.

    The recorder stops reporting progress first, so a lockstep producer stops
    at most ``simulation.max_samples_ahead`` samples later; those, and
    everything before them, are taken until the topics have been quiet for
    :data:`DRAIN_QUIET_S` (at most :data:`DRAIN_LIMIT_S`: a producer that does not
    wait for it would never let the topics go quiet).

    Parameters
    ----------
    recorder : BagRecorderNode
    spin : callable
        ``spin(timeout_s)`` runs the recorder's callbacks once (``executor.spin_once``).
    """
    recorder.stop_reporting()
    started = time.monotonic()
    while time.monotonic() - started < DRAIN_LIMIT_S and time.monotonic() - recorder.last_message_at < DRAIN_QUIET_S:
        spin(0.05)


class RunRecording:
    """Records an in-process node-set run (``pmr-ros run --bag``) into a bag.

    :meth:`nodes` is the ``extra_nodes`` hook of
    :func:`pmr_ros.node_set.run_node_set`: it adds a recorder whose
    configuration is every parameter the nodes got, and whose ``done`` waits
    for the whole run and its final verdicts.

    Parameters
    ----------
    writer : BagWriter
    source : str
        The params file the run was configured from.
    samples : int
        The run's length [samples].
    namespace : str
        The node set's namespace.
    """

    def __init__(self, writer: BagWriter, source: str, samples: int, *, namespace: str = "/") -> None:
        self.writer, self.source, self.samples, self.namespace = writer, source, samples, namespace
        self.recorder: BagRecorderNode | None = None

    def nodes(self, context, parameters: dict) -> list[Node]:
        """The ``extra_nodes`` hook: a recorder of every contract topic with the run's parameters."""
        config = RunConfig(nested(parameters), source=self.source)
        self.recorder = BagRecorderNode(
            self.writer,
            run_config=config,
            parameter_source=None,
            expected_samples=self.samples,
            context=context,
            namespace=self.namespace,
        )
        return [self.recorder]

    def close(self) -> None:
        """Close the bag (also after a failed run: what was recorded stays readable)."""
        if self.recorder is not None:
            self.recorder.close()
        else:
            self.writer.close()
