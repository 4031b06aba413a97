"""Node parameters: the same dotted names as the config files, validated by the core.

Every node declares every parameter of ``config/defaults.yaml`` laid under the
shipped system file, so ``--ros-args --params-file config/wood_berry.yaml``
(one ``/**`` section) configures all four nodes alike.  The descriptions are
the comments of those files; ranges are added where a parameter is a scalar.
A node's full parameter set is validated by rebuilding the nested tree and
calling :func:`pmr_ros.core.config.parse_config` plus :func:`parse_node_settings`,
so nodes and the batch core give the same error messages.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass
from functools import cache
from typing import Any

from ..core.config import DEFAULT_SYSTEM, DEFAULTS_FILE, ConfigError, config_dir, flatten_parameters, load_config, parse_config

INT_RANGES: dict[str, tuple[int, int]] = {
    "run.samples": (1, 2**31 - 1),
    "run.seed": (0, 2**31 - 1),
    "prbs.register_length": (3, 24),
    "prbs.clock_period": (1, 1_000_000),
    "mpc.prediction_horizon": (1, 100_000),
    "mpc.control_horizon": (1, 100_000),
    "pmr.segment_length": (16, 2**24),
    "pmr.max_delay_samples": (1, 100_000),
    "simulation.wait_for_subscribers": (0, 1000),
    "diagnostician.window_samples": (1, 2**31 - 1),
    "diagnostician.update_period_samples": (1, 2**31 - 1),
    "diagnostician.min_samples": (1, 2**31 - 1),
    "diagnostician.max_lag_samples": (1, 2**31 - 1),
}
"""Inclusive ranges of integer parameters, shown in their descriptors."""

FLOAT_RANGES: dict[str, tuple[float, float]] = {
    "system.sample_time": (1e-9, 1e9),
    "pmr.overlap": (0.0, 0.99),
    "pmr.tau_band": (1e-6, math.pi),
    "simulation.real_time_rate_hz": (0.0, 1e6),
    "simulation.startup_timeout_s": (0.0, 1e6),
    "diagnostician.stale_timeout_s": (1e-3, 1e6),
}
"""Inclusive ranges of floating-point parameters, shown in their descriptors."""


@dataclass(frozen=True)
class NodeSettings:
    """Settings of the node set that the batch core does not use.

    Attributes
    ----------
    real_time_rate_hz : float
        0: lockstep (the plant steps on u(k)); > 0: wall-clock samples per second.
    wait_for_subscribers : int
        Subscribers of y the plant waits for before sample 0.
    startup_timeout_s : float
        Longest wait for them [s].
    window_samples, update_period_samples, min_samples, max_lag_samples : int
        Diagnostician window, publishing period, shortest diagnosable stretch
        and the lag at which a signal counts as stopped [samples].
    stale_timeout_s : float
        Silence of a signal after which the verdicts turn STALE [s, wall time].
    """

    real_time_rate_hz: float
    wait_for_subscribers: int
    startup_timeout_s: float
    window_samples: int
    update_period_samples: int
    min_samples: int
    max_lag_samples: int
    stale_timeout_s: float

    @property
    def lockstep(self) -> bool:
        return self.real_time_rate_hz == 0


def _lookup(tree: dict, field: str, source: str) -> Any:
    node: Any = tree
    for part in field.split("."):
        if not isinstance(node, dict) or part not in node:
            raise ConfigError(source, field, None, "missing")
        node = node[part]
    return node


def _number(tree: dict, field: str, source: str, *, integer: bool, minimum: float, strict: bool = False) -> float:
    value = _lookup(tree, field, source)
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise ConfigError(source, field, value, "must be a finite number")
    if integer and float(value) != int(value):
        raise ConfigError(source, field, value, "must be a whole number")
    if value < minimum or (strict and value == minimum):
        raise ConfigError(source, field, value, f"must be {'>' if strict else '>='} {minimum:g}")
    return int(value) if integer else float(value)


def parse_node_settings(tree: dict, source: str) -> NodeSettings:
    """Validate the node-set settings of a nested parameter tree.

    Raises
    ------
    ConfigError
        Naming the parameter and its value.
    """
    settings = NodeSettings(
        real_time_rate_hz=_number(tree, "simulation.real_time_rate_hz", source, integer=False, minimum=0.0),
        wait_for_subscribers=_number(tree, "simulation.wait_for_subscribers", source, integer=True, minimum=0),
        startup_timeout_s=_number(tree, "simulation.startup_timeout_s", source, integer=False, minimum=0.0),
        window_samples=_number(tree, "diagnostician.window_samples", source, integer=True, minimum=1),
        update_period_samples=_number(tree, "diagnostician.update_period_samples", source, integer=True, minimum=1),
        min_samples=_number(tree, "diagnostician.min_samples", source, integer=True, minimum=1),
        max_lag_samples=_number(tree, "diagnostician.max_lag_samples", source, integer=True, minimum=1),
        stale_timeout_s=_number(tree, "diagnostician.stale_timeout_s", source, integer=False, minimum=0.0, strict=True),
    )
    if settings.min_samples > settings.window_samples:
        raise ConfigError(source, "diagnostician.min_samples", settings.min_samples, f"must not exceed diagnostician.window_samples ({settings.window_samples})")
    return settings


def nested(flat: dict[str, Any]) -> dict:
    """Dotted names to a nested tree (the inverse of ``flatten_parameters``)."""
    tree: dict = {}
    for name, value in flat.items():
        node = tree
        parts = name.split(".")
        for part in parts[:-1]:
            node = node.setdefault(part, {})
        node[parts[-1]] = value
    return tree


def validate(flat: dict[str, Any], source: str):
    """``(PmrConfig, NodeSettings)`` of dotted parameters; raises :class:`ConfigError`."""
    tree = nested(flat)
    return parse_config(tree, source), parse_node_settings(tree, source)


_LINE = re.compile(r"^(?P<indent>\s*)(?P<key>[A-Za-z_][\w]*):(?P<rest>[^#]*)(#\s*(?P<comment>.*))?$")


def comment_descriptions(text: str) -> dict[str, str]:
    """Dotted parameter name -> its end-of-line comment in a params file's text."""
    out: dict[str, str] = {}
    stack: list[tuple[int, str]] = []
    for line in text.splitlines():
        match = _LINE.match(line)
        if not match:
            continue
        indent = len(match["indent"])
        while stack and stack[-1][0] >= indent:
            stack.pop()
        stack.append((indent, match["key"]))
        names = [k for _, k in stack]
        if "ros__parameters" not in names:
            continue
        dotted = ".".join(names[names.index("ros__parameters") + 1:])
        if dotted and match["comment"] and match["rest"].strip():
            out[dotted] = match["comment"].strip()
    return out


@cache
def default_parameters() -> dict[str, Any]:
    """Dotted name -> default of every node parameter (defaults under the shipped system)."""
    return flatten_parameters(load_config().parameters)


@cache
def parameter_descriptions() -> dict[str, str]:
    """Dotted name -> description, from the comments of the shipped files."""
    out: dict[str, str] = {}
    for file in (DEFAULTS_FILE, DEFAULT_SYSTEM):
        out.update(comment_descriptions((config_dir() / file).read_text()))
    return out


def describe(name: str) -> str:
    """The description of a parameter (its config-file comment, or a generic line)."""
    text = parameter_descriptions().get(name)
    if text:
        return text
    return f"{name} (see config/{DEFAULTS_FILE}; matrices are row-major flat lists, per-channel values may be one number)"


def ros_value(value: Any) -> Any:
    """A config value as a ROS parameter value: lists mixing ints and floats become floats."""
    if isinstance(value, list):
        if any(isinstance(v, float) for v in value) and all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in value):
            return [float(v) for v in value]
        return list(value)
    return value


def parameter_overrides(flat: dict[str, Any]):
    """``rclpy.parameter.Parameter`` list of dotted values, for in-process nodes."""
    from rclpy.parameter import Parameter

    return [Parameter(name, value=ros_value(value)) for name, value in flat.items()]
