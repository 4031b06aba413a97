"""What every pmr_ros node shares: parameters validated by the core, clean start and stop."""

from __future__ import annotations

import sys
from collections.abc import Callable
from typing import Any

from rcl_interfaces.msg import FloatingPointRange, IntegerRange, ParameterDescriptor, SetParametersResult
from rclpy.exceptions import InvalidParameterTypeException, InvalidParameterValueException
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.parameter import Parameter

from ..core.config import ConfigError
from .contract import ContractError, topic
from .parameters import FLOAT_RANGES, INT_RANGES, default_parameters, describe, ros_value, validate
from .signals import RosInitError, rclpy_session

SPIN_TIMEOUT_S = 0.1
"""Longest a node process takes to notice Ctrl-C or SIGTERM [s]."""


def descriptor(name: str) -> ParameterDescriptor:
    """The descriptor of a config parameter: description, range if scalar, any type.

    Dynamic typing because a per-channel setting may be one number or a list;
    :func:`pmr_ros.ros.parameters.validate` checks types and values instead.
    """
    desc = ParameterDescriptor(name=name, description=describe(name), dynamic_typing=True)
    if name in INT_RANGES:
        low, high = INT_RANGES[name]
        desc.integer_range = [IntegerRange(from_value=low, to_value=high, step=0)]
        desc.additional_constraints = f"whole number in [{low}, {high}]"
    elif name in FLOAT_RANGES:
        low, high = FLOAT_RANGES[name]
        desc.floating_point_range = [FloatingPointRange(from_value=low, to_value=high, step=0.0)]
        desc.additional_constraints = f"number in [{low:g}, {high:g}]"
    return desc


class ConfiguredNode(Node):
    """A node with every pmr_ros parameter declared and validated.

    Attributes
    ----------
    config : PmrConfig
        The validated configuration (core types).
    settings : NodeSettings
        Node-set settings (timing, diagnostician window).

    Parameters
    ----------
    node_name : str
    live_parameters : bool
        Whether valid runtime changes are accepted (the diagnostician) or
        refused because the node built its simulation from them at start.
    sim_time : bool
        Force ``use_sim_time``: the simulation nodes run on the plant's /clock.
    **kwargs
        Passed to :class:`rclpy.node.Node` (``context``, ``parameter_overrides``).
    """

    def __init__(self, node_name: str, *, live_parameters: bool = False, sim_time: bool = False, **kwargs: Any) -> None:
        super().__init__(node_name, **kwargs)
        if sim_time:
            self.set_parameters([Parameter("use_sim_time", value=True)])
        self._live_parameters = live_parameters
        self._source = f"parameters of node {self.get_fully_qualified_name()}"
        defaults = default_parameters()
        declared = []
        for name, value in defaults.items():
            try:
                declared.append(self.declare_parameter(name, ros_value(value), descriptor(name)))
            except (InvalidParameterValueException, InvalidParameterTypeException) as exc:
                given = self._parameter_overrides[name].value if name in self._parameter_overrides else value
                raise ConfigError(self._source, name, given, str(exc).split(": ", 1)[-1]) from None
        self.config, self.settings = validate(self._current(), self._source)
        self.add_on_set_parameters_callback(self._on_set_parameters)

    def _current(self, changes: dict[str, Any] | None = None) -> dict[str, Any]:
        flat = {name: self.get_parameter(name).value for name in default_parameters()}
        flat = {k: (list(v) if hasattr(v, "tolist") or isinstance(v, (tuple, list)) else v) for k, v in flat.items()}
        flat.update(changes or {})
        return flat

    def _on_set_parameters(self, parameters: list[Parameter]) -> SetParametersResult:
        ours = {p.name: (list(p.value) if isinstance(p.value, (list, tuple)) or hasattr(p.value, "tolist") else p.value) for p in parameters if p.name in default_parameters()}
        if not ours:
            return SetParametersResult(successful=True)
        try:
            config, settings = validate(self._current(ours), self._source)
        except ConfigError as exc:
            self.get_logger().warning(f"parameter change refused: {exc}")
            return SetParametersResult(successful=False, reason=str(exc))
        if not self._live_parameters:
            reason = f"{', '.join(sorted(ours))}: {self.get_name()} builds its simulation from its parameters at start; restart it to change them"
            return SetParametersResult(successful=False, reason=reason)
        self.config, self.settings = config, settings
        self.on_configuration_changed(sorted(ours))
        return SetParametersResult(successful=True)

    def on_configuration_changed(self, names: list[str]) -> None:
        """Hook of live nodes: ``self.config``/``self.settings`` now hold the new values."""

    # -- topics of the contract --------------------------------------------
    def contract_publisher(self, key: str):
        """A publisher of contract topic ``key`` with the contract's type and QoS."""
        t = topic(key)
        return self.create_publisher(t.message_class(), t.name, t.qos.profile())

    def contract_subscription(self, key: str, callback: Callable):
        """A subscription to contract topic ``key`` with the contract's type and QoS."""
        t = topic(key)
        return self.create_subscription(t.message_class(), t.name, callback, t.qos.profile())


def run_node(factory: Callable[[], Node], program: str, args: list[str] | None = None) -> int:
    """Init rclpy, build the node, spin until Ctrl-C/SIGTERM, shut down; the exit code.

    Configuration errors end with one line on stderr and exit code 2, never a
    traceback; Ctrl-C and SIGTERM end with 0 (see :mod:`pmr_ros.ros.signals`).
    """
    node = executor = None
    try:
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
