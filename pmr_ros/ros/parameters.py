"""Node parameters from the declaration: which a node declares, their descriptors and values.

Each executable declares the parameters of the blocks it uses (``nodes`` in
``config/parameters.yaml``), with the declared default, description and
range; so ``--ros-args --params-file config/wood_berry.yaml`` (one ``/**``
section) configures all four nodes alike, and each ignores the blocks of the
others.  The ``system`` parameters have no default: a node started without a
model refuses to start.
"""

from __future__ import annotations

from typing import Any

from rcl_interfaces.msg import FloatingPointRange, IntegerRange, ParameterDescriptor

from ..config import schema
from ..config.schema import Parameter

__all__ = ["ROS_OWN_PARAMETERS", "descriptor", "node_parameters", "parameter_overrides", "plain_value", "ros_value"]

ROS_OWN_PARAMETERS = ("use_sim_time", "start_type_description_service", "qos_overrides.")
"""Parameters (or prefixes) rclpy itself declares or reads; never checked against the declaration."""


def node_parameters(node: str) -> list[Parameter]:
    """The declared parameters ``node`` (an executable's name) uses, in declaration order."""
    return [p for p in schema.parameters().values() if node in p.nodes]


def descriptor(parameter: Parameter, *, read_only: bool) -> ParameterDescriptor:
    """The ROS descriptor of a declared parameter: description, range (if numeric), read-only flag.

    Dynamic typing: a per-channel setting may be one number or a list, and a
    list of whole numbers may be read as integers;
    :func:`pmr_ros.config.parse_config` checks types and values instead.
    """
    desc = ParameterDescriptor(
        name=parameter.name, description=parameter.describe(), dynamic_typing=True, read_only=read_only
    )
    low, high = parameter.minimum, parameter.maximum
    if parameter.kind == "int" and low is not None and high is not None:
        desc.integer_range = [IntegerRange(from_value=int(low), to_value=int(high), step=0)]
    elif (
        parameter.kind == "float"
        and low is not None
        and high is not None
        and not (parameter.min_exclusive or parameter.max_exclusive)
    ):
        desc.floating_point_range = [FloatingPointRange(from_value=float(low), to_value=float(high), step=0.0)]
    constraints = parameter.range_text()
    if constraints:
        desc.additional_constraints = constraints
    return desc


def ros_value(value: Any) -> Any:
    """A config value as a ROS parameter value: lists mixing ints and floats become floats."""
    if isinstance(value, (list, tuple)):
        if any(isinstance(v, float) for v in value) and all(
            isinstance(v, (int, float)) and not isinstance(v, bool) for v in value
        ):
            return [float(v) for v in value]
        return list(value)
    return value


def plain_value(value: Any) -> Any:
    """A ROS parameter value as plain Python (arrays and tuples to lists)."""
    if hasattr(value, "tolist"):
        return value.tolist()
    if isinstance(value, tuple):
        return list(value)
    return value


def parameter_overrides(flat: dict[str, Any]) -> list[Any]:
    """``rclpy.parameter.Parameter`` list of dotted values, for in-process nodes.

    Parameters of a block no node declares (``data``: read by ``pmr-ros``
    alone; its lists mix numbers and strings, which no ROS parameter can hold)
    are left out; unknown names stay, so a node refuses a typo.
    """
    from rclpy.parameter import Parameter as RosParameter

    declared = schema.parameters()
    return [
        RosParameter(name, value=ros_value(value))
        for name, value in flat.items()
        if name not in declared or declared[name].nodes
    ]
