"""What every pmr_ros node shares: declared parameters checked by the config reader, contract topics, start and stop."""

from __future__ import annotations

import sys
from collections.abc import Callable
from typing import Any

from rcl_interfaces.msg import SetParametersResult
from rclpy.exceptions import InvalidParameterTypeException, InvalidParameterValueException
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.parameter import Parameter

from ..config import ConfigError, PmrConfig, nested, parse_config
from ..config.files import check_parameter_files
from ..config.schema import closest_name, parameters
from ..contract.topics import ContractError, topic
from .messages import message_class, qos_profile
from .parameters import ROS_OWN_PARAMETERS, descriptor, node_parameters, plain_value, ros_value
from .signals import RosInitError, rclpy_session

__all__ = ["SPIN_TIMEOUT_S", "ConfiguredNode", "run_node"]

SPIN_TIMEOUT_S = 0.1
"""Longest a node process takes to notice Ctrl-C or SIGTERM [s]."""


class ConfiguredNode(Node):
    """A node with the declared parameters of its executable, validated into a :class:`PmrConfig`.

    Attributes
    ----------
    config : PmrConfig
        The validated configuration (blocks the node does not declare take
        their declared defaults).

    Parameters
    ----------
    node_name : str
    executable : str
        The executable whose parameters the node declares (``nodes`` in ``config/parameters.yaml``).
    live_parameters : bool
        Valid runtime changes are accepted (the diagnostician); otherwise only
        the parameters whose block lists the executable as ``live`` accept a
        change (``mpc_controller``: the ``system`` block, a new model), and every
        other one is read-only (the node built its simulation from them at start).
    sim_time : bool
        The node lives on the plant's clock: ``use_sim_time`` defaults to true
        (a value given explicitly, e.g. ``-p use_sim_time:=false``, is kept),
        and its time source follows the contract's clock topic in the node's
        namespace (``/column_a/clock``).
    **kwargs
        Passed to :class:`rclpy.node.Node` (``context``, ``parameter_overrides``).

    Raises
    ------
    ConfigError
        A parameter given to the node is unknown (with the nearest known name),
        the model (``system``) is missing, or a value is invalid.
    """

    def __init__(
        self, node_name: str, *, executable: str, live_parameters: bool = False, sim_time: bool = False, **kwargs: Any
    ) -> None:
        if sim_time:
            # the time source (use_sim_time) listens to /clock; the node set's clock is the contract's, relative
            # to the namespace like every contract topic: remap one onto the other (a no-op in the root namespace)
            kwargs["cli_args"] = [*(kwargs.get("cli_args") or []), "--ros-args", "-r", f"/clock:={topic('clock').name}"]
        super().__init__(node_name, **kwargs)
        if sim_time and "use_sim_time" not in self._parameter_overrides:
            self.set_parameters([Parameter("use_sim_time", value=True)])
        self._live_parameters = live_parameters
        self._source = f"parameters of node {self.get_fully_qualified_name()}"
        self._declared = [p.name for p in node_parameters(executable)]
        try:
            self._configure(executable)
            self.check_start(self.config)
        except ConfigError:
            Node.destroy_node(self)  # refused at start: nothing left in the graph (not the subclass's, half-built)
            raise
        if live_parameters or any(executable in spec.live for spec in node_parameters(executable)):
            self.add_on_set_parameters_callback(self._on_set_parameters)

    def _configure(self, executable: str) -> None:
        """Declare the executable's parameters and build :attr:`config` from what was given."""
        self._check_overrides()
        for spec in node_parameters(executable):
            self._declare(spec, read_only=not (self._live_parameters or executable in spec.live))
        # what was given, as a params file would give it: the declared defaults fill the rest
        self._given = {n: plain_value(p.value) for n, p in self._parameter_overrides.items() if n in self._declared}
        self.config: PmrConfig = self._build(self._current())
        for warning in self.config.warnings:
            self.get_logger().warning(warning)

    def _check_overrides(self) -> None:
        """A parameter given to this node that pmr_ros does not declare is a typo: refuse it."""
        known = parameters()
        for name, given in self._parameter_overrides.items():
            if name in known or name.startswith(ROS_OWN_PARAMETERS):
                continue
            guess = closest_name(name)
            hint = f"; did you mean {guess}?" if guess else ""
            raise ConfigError(self._source, name, plain_value(given.value), f"unknown parameter{hint}")

    def _declare(self, spec: Any, *, read_only: bool) -> None:
        value = None if spec.required else ros_value(spec.default)
        try:
            if value is None:
                self.declare_parameter(spec.name, descriptor=descriptor(spec, read_only=read_only))
            else:
                self.declare_parameter(spec.name, value, descriptor(spec, read_only=read_only))
        except (InvalidParameterValueException, InvalidParameterTypeException) as exc:
            given = self._parameter_overrides[spec.name].value if spec.name in self._parameter_overrides else value
            raise ConfigError(self._source, spec.name, plain_value(given), str(exc).split(": ", 1)[-1]) from None

    def _current(self, changes: dict[str, Any] | None = None) -> dict[str, Any]:
        flat = {**self._given, **(changes or {})}
        return {name: value for name, value in flat.items() if value is not None}

    def _build(self, flat: dict[str, Any]) -> PmrConfig:
        return parse_config(nested(flat), self._source)

    def _on_set_parameters(self, changes: list[Parameter]) -> SetParametersResult:
        ours = {p.name: plain_value(p.value) for p in changes if p.name in self._declared}
        if not ours:
            return SetParametersResult(successful=True)
        try:
            config = self._build(self._current(ours))
        except ConfigError as exc:
            self.get_logger().warning(f"parameter change refused: {exc}")
            return SetParametersResult(successful=False, reason=str(exc))
        problem = self.check_configuration(config, sorted(ours))
        if problem:
            reason = f"{self._source}: {problem}"
            self.get_logger().warning(f"parameter change refused: {reason}")
            return SetParametersResult(successful=False, reason=reason)
        self.config = config
        self._given.update(ours)
        self.on_configuration_changed(sorted(ours))
        return SetParametersResult(successful=True)

    def check_start(self, config: PmrConfig) -> None:
        """Hook: refuse, before the node builds anything, a configuration it cannot run (raise ConfigError).

        Called once the parameters are read; the node is destroyed again and its
        entry point prints the one line (e.g. a plant too large for the memory).
        """

    def check_configuration(self, config: PmrConfig, names: list[str]) -> str | None:
        """Hook of live nodes: why ``config`` (valid as a params file) cannot be taken now, in one line, or None."""
        return None

    def on_configuration_changed(self, names: list[str]) -> None:
        """Hook of live nodes: ``self.config`` now holds the new values."""

    # -- topics of the contract --------------------------------------------
    def contract_publisher(self, key: str) -> Any:
        """A publisher of contract topic ``key`` with the contract's type and QoS."""
        t = topic(key)
        return self.create_publisher(message_class(t), t.name, qos_profile(t.qos))

    def contract_subscription(self, key: str, callback: Callable[..., None], *, raw: bool = False) -> Any:
        """A subscription to contract topic ``key`` with the contract's type and QoS.

        A message the callback fails on is rejected with one logged line and the
        node goes on as it was: no message on a topic may end a node.
        """
        t = topic(key)
        name = t.name

        def guarded(msg: Any) -> None:
            try:
                callback(msg)
            except Exception as exc:  # a message's content must never crash the node; say why it was dropped
                cause = " ".join(f"{type(exc).__name__}: {exc}".split())[:300]
                self.get_logger().error(f"a message on {self.resolve_topic_name(name)} was rejected: {cause}")

        return self.create_subscription(message_class(t), name, guarded, qos_profile(t.qos), raw=raw)


def run_node(factory: Callable[[], Node], program: str, args: list[str] | None = None) -> int:
    """Init rclpy, build the node, spin until Ctrl-C/SIGTERM, shut down; the exit code.

    Configuration errors end with one line on stderr and exit code 2, never a
    traceback; Ctrl-C and SIGTERM end with 0 (see :mod:`pmr_ros.ros.signals`).
    """
    node = executor = None
    try:
        check_parameter_files(list(sys.argv if args is None else args))
        with rclpy_session(args) as stop:
            try:
                node = factory()
                executor = SingleThreadedExecutor()
                executor.add_node(node)
                while not stop:
                    executor.spin_once(timeout_sec=SPIN_TIMEOUT_S)
            finally:
                if executor is not None:
                    executor.shutdown(timeout_sec=1.0)
                if node is not None:
                    node.destroy_node()
    except (RosInitError, ConfigError, ContractError) as exc:
        print(f"{program}: error: {exc}", file=sys.stderr)
        return 2
    return 0
