"""Loading and validating a pmr_ros configuration.

A configuration is a standard ROS 2 parameter file: everything sits under
``/**: ros__parameters:`` so that one file configures every node and the batch
core alike.  Matrices are row-major flat lists (ROS parameters have no nested
arrays).  A user file is laid over ``config/defaults.yaml``; it needs at least
the ``system`` block.  Per-channel settings may be a scalar, applied to every
channel.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from ..resources import share_dir
from .foptd import SCENARIOS, FoptdMatrix, Mismatch, element_name
from .mpc import MpcTuning
from .parametric import ParametricSettings
from .pmr import METHODS, PmrSettings
from .prbs import PrbsSettings

DEFAULT_SYSTEM = "wood_berry.yaml"
DEFAULTS_FILE = "defaults.yaml"


class ConfigError(ValueError):
    """A configuration value is invalid; the message names the file and field."""

    def __init__(self, source: str | Path, field: str, value: Any, reason: str) -> None:
        self.source, self.field, self.value, self.reason = str(source), field, value, reason
        super().__init__(f"{source}: {field} = {value!r}: {reason}")


def config_dir() -> Path:
    """The folder with the shipped configuration files (see :func:`share_dir`)."""
    return share_dir("config", DEFAULTS_FILE)


@dataclass(frozen=True)
class RunSettings:
    """How long and with what seed and scenario the closed loop runs."""

    samples: int
    seed: int
    scenario: str


@dataclass(frozen=True)
class PmrConfig:
    """Everything a run needs: the model, the mismatch, the loop and the diagnosis."""

    model: FoptdMatrix
    mismatch: Mismatch
    noise_std: np.ndarray
    prbs: PrbsSettings
    mpc: MpcTuning
    pmr: PmrSettings
    parametric: ParametricSettings
    run: RunSettings
    source: str
    parameters: dict[str, Any]

    def plant(self, scenario: str | None = None) -> FoptdMatrix:
        """The true plant ``G`` under ``scenario`` (default: the configured one)."""
        return self.model.with_mismatch(self.mismatch.for_scenario(scenario or self.run.scenario))


def _merge(base: dict, over: dict) -> dict:
    out = dict(base)
    for key, value in over.items():
        if isinstance(value, dict) and isinstance(out.get(key), dict):
            out[key] = _merge(out[key], value)
        else:
            out[key] = value
    return out


def flatten_parameters(tree: dict, prefix: str = "") -> dict[str, Any]:
    """Nested parameter dict to ROS 2 dotted names (``system.gain``)."""
    flat: dict[str, Any] = {}
    for key, value in tree.items():
        name = f"{prefix}{key}"
        if isinstance(value, dict):
            flat.update(flatten_parameters(value, name + "."))
        else:
            flat[name] = value
    return flat


def read_parameter_file(path: str | Path) -> dict[str, Any]:
    """The ``ros__parameters`` of a params file as a nested dict.

    Accepts the wildcard section ``/**`` or a single node section.
    """
    path = Path(path)
    try:
        text = path.read_text()
    except OSError as exc:
        raise ConfigError(path, "<file>", str(path), f"cannot read: {exc.strerror or exc}") from None
    try:
        doc = yaml.safe_load(text)
    except yaml.YAMLError as exc:
        raise ConfigError(path, "<file>", str(path), f"not valid YAML: {exc}") from None
    if not isinstance(doc, dict):
        raise ConfigError(path, "<file>", type(doc).__name__, "expected a ROS 2 params file (a mapping)")
    sections = [v for v in doc.values() if isinstance(v, dict) and "ros__parameters" in v]
    if "/**" in doc and isinstance(doc["/**"], dict) and "ros__parameters" in doc["/**"]:
        params = doc["/**"]["ros__parameters"]
    elif len(sections) == 1:
        params = sections[0]["ros__parameters"]
    else:
        raise ConfigError(path, "/**.ros__parameters", None, "missing: put the parameters under '/**: ros__parameters:'")
    if not isinstance(params, dict):
        raise ConfigError(path, "ros__parameters", params, "must be a mapping")
    return params


class _Reader:
    """Typed, validating access to dotted fields of a parameter tree."""

    def __init__(self, params: dict, source: str | Path) -> None:
        self.params, self.source = params, source

    def raw(self, field: str) -> Any:
        node: Any = self.params
        for part in field.split("."):
            if not isinstance(node, dict) or part not in node:
                raise ConfigError(self.source, field, None, "missing")
            node = node[part]
        return node

    def error(self, field: str, value: Any, reason: str) -> ConfigError:
        return ConfigError(self.source, field, value, reason)

    def check_item(self, name: str, item: Any, *, positive: bool = False, nonnegative: bool = False) -> float:
        """One entry of a list: a finite number, with the sign asked for."""
        if isinstance(item, bool) or not isinstance(item, (int, float)):
            raise self.error(name, item, "must be a number")
        if not math.isfinite(item):
            raise self.error(name, item, "must be finite")
        if positive and item <= 0:
            raise self.error(name, item, "must be > 0")
        if nonnegative and item < 0:
            raise self.error(name, item, "must be >= 0")
        return float(item)

    def number(self, field: str, *, integer: bool = False, positive: bool = False, minimum: float | None = None) -> float:
        value = self.raw(field)
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise self.error(field, value, "must be a number")
        if not math.isfinite(value):
            raise self.error(field, value, "must be finite")
        if integer and float(value) != int(value):
            raise self.error(field, value, "must be a whole number")
        if positive and value <= 0:
            raise self.error(field, value, "must be > 0")
        if minimum is not None and value < minimum:
            raise self.error(field, value, f"must be >= {minimum:g}")
        return int(value) if integer else float(value)

    def text(self, field: str, choices: tuple[str, ...] | None = None) -> str:
        value = self.raw(field)
        if not isinstance(value, str):
            raise self.error(field, value, "must be a string")
        if choices and value not in choices:
            raise self.error(field, value, f"must be one of {', '.join(choices)}")
        return value

    def vector(self, field: str, length: int, *, positive: bool = False, nonnegative: bool = False) -> np.ndarray:
        """A per-channel list, or a scalar applied to every channel."""
        value = self.raw(field)
        items = value if isinstance(value, list) else [value]
        if isinstance(value, list) and len(value) != length:
            raise self.error(field, value, f"needs {length} entries (one per channel), got {len(value)}")
        out = [
            self.check_item(f"{field}[{j}]" if isinstance(value, list) else field, item, positive=positive, nonnegative=nonnegative)
            for j, item in enumerate(items)
        ]
        return np.broadcast_to(np.array(out), (length,)).copy()

    def names(self, field: str, length: int | None = None) -> tuple[str, ...]:
        value = self.raw(field)
        if not isinstance(value, list) or not value or not all(isinstance(v, str) and v for v in value):
            raise self.error(field, value, "must be a non-empty list of names")
        if len(set(value)) != len(value):
            raise self.error(field, value, "names must be unique")
        if length is not None and len(value) != length:
            raise self.error(field, value, f"needs {length} names, got {len(value)}")
        return tuple(value)

    def matrix(self, field: str, n_out: int, n_in: int, *, positive: bool = False, nonnegative: bool = False, scalar: bool = False) -> np.ndarray:
        """A row-major flat list of n_out*n_in numbers (a list of rows is accepted too).

        With ``scalar``, one number stands for every element.
        """
        value = self.raw(field)
        if scalar and isinstance(value, (int, float)) and not isinstance(value, bool):
            value = [value] * (n_out * n_in)
        if not isinstance(value, list):
            raise self.error(field, value, f"must be a list of {n_out}x{n_in} = {n_out * n_in} numbers, row by row")
        if value and all(isinstance(row, list) for row in value):
            lengths = [len(row) for row in value]
            if len(value) != n_out or any(n != n_in for n in lengths):
                raise self.error(field, value, f"must be {n_out} rows of {n_in} (got rows of {lengths}); the matrix must be square and not ragged")
            value = [x for row in value for x in row]
        if len(value) != n_out * n_in:
            raise self.error(field, value, f"needs {n_out * n_in} entries ({n_out}x{n_in}, row by row), got {len(value)}")
        names = [f"{field}[{j}] ({element_name(*divmod(j, n_in), max(n_out, n_in))})" for j in range(n_out * n_in)]
        out = [self.check_item(name, item, positive=positive, nonnegative=nonnegative) for name, item in zip(names, value, strict=True)]
        return np.array(out).reshape(n_out, n_in)


def parse_config(params: dict, source: str | Path) -> PmrConfig:
    """Validate a nested parameter tree (defaults already merged) into a :class:`PmrConfig`."""
    rd = _Reader(params, source)
    outputs = rd.names("system.output_names")
    inputs = rd.names("system.input_names")
    n_out, n_in = len(outputs), len(inputs)
    if n_out != n_in:
        raise rd.error("system.input_names", list(inputs), f"the matrix must be square: {n_out} outputs but {n_in} inputs")
    ts = rd.number("system.sample_time", positive=True)
    gain = rd.matrix("system.gain", n_out, n_in)
    if np.any(gain == 0):
        j = int(np.flatnonzero(gain.ravel() == 0)[0])
        raise rd.error(f"system.gain[{j}]", 0.0, "must be non-zero: the plant-model ratio divides by the model gain")
    tau = rd.matrix("system.time_constant", n_out, n_in, positive=True)
    delay = rd.matrix("system.delay", n_out, n_in, nonnegative=True)
    whole = delay / ts
    bad = np.flatnonzero(np.abs(whole - np.rint(whole)).ravel() > 1e-9 * np.maximum(1.0, np.abs(whole).ravel()))
    if bad.size:
        j = int(bad[0])
        raise rd.error(f"system.delay[{j}]", float(delay.ravel()[j]), f"must be a whole number of samples (sample_time = {ts:g})")
    model = FoptdMatrix(gain, tau, np.rint(whole) * ts, ts, outputs, inputs, str(rd.raw("system.name")) if _has(params, "system.name") else "")

    gain_pct = rd.matrix("mismatch.gain_pct", n_out, n_in, scalar=True)
    tau_pct = rd.matrix("mismatch.time_constant_pct", n_out, n_in, scalar=True)
    ddel = rd.matrix("mismatch.delay_samples", n_out, n_in, scalar=True)
    if np.any(gain_pct <= -100):
        raise rd.error("mismatch.gain_pct", gain_pct.ravel().tolist(), "must be > -100 (the plant gain must keep its sign)")
    if np.any(tau_pct <= -100):
        raise rd.error("mismatch.time_constant_pct", tau_pct.ravel().tolist(), "must be > -100 (time constants stay positive)")
    if np.any(ddel != np.rint(ddel)):
        raise rd.error("mismatch.delay_samples", ddel.ravel().tolist(), "must be whole numbers of samples")
    if np.any(model.delay_samples + ddel < 0):
        raise rd.error("mismatch.delay_samples", ddel.ravel().tolist(), "would make a plant delay negative")
    mismatch = Mismatch(gain_pct, tau_pct, np.rint(ddel).astype(int))

    noise = rd.vector("noise.std", n_out, nonnegative=True)
    register = rd.number("prbs.register_length", integer=True, minimum=3)
    if register > 24:
        raise rd.error("prbs.register_length", register, "must be <= 24")
    prbs = PrbsSettings(
        register_length=register,
        clock_period=rd.number("prbs.clock_period", integer=True, positive=True),
        amplitude=rd.vector("prbs.amplitude", n_out, nonnegative=True),
        nominal=rd.vector("prbs.nominal", n_out),
    )
    np_h = rd.number("mpc.prediction_horizon", integer=True, positive=True)
    nc_h = rd.number("mpc.control_horizon", integer=True, positive=True)
    if nc_h > np_h:
        raise rd.error("mpc.control_horizon", nc_h, f"must not exceed mpc.prediction_horizon ({np_h})")
    if np_h <= int(model.delay_samples.max()):
        raise rd.error("mpc.prediction_horizon", np_h, f"must exceed the largest delay ({int(model.delay_samples.max())} samples)")
    u_min = rd.vector("mpc.u_min", n_in)
    u_max = rd.vector("mpc.u_max", n_in)
    if np.any(u_min >= u_max):
        raise rd.error("mpc.u_min", u_min.tolist(), "must be below mpc.u_max")
    mpc = MpcTuning(
        prediction_horizon=np_h,
        control_horizon=nc_h,
        output_weight=rd.vector("mpc.output_weight", n_out, nonnegative=True),
        move_weight=rd.vector("mpc.move_weight", n_in, positive=True),
        u_min=u_min,
        u_max=u_max,
        du_max=rd.vector("mpc.du_max", n_in, positive=True),
    )
    pmr = PmrSettings(
        method=rd.text("pmr.method", METHODS),
        window=rd.text("pmr.window"),
        segment_length=rd.number("pmr.segment_length", integer=True, minimum=16),
        overlap=rd.number("pmr.overlap", minimum=0.0),
        tau_band=rd.number("pmr.tau_band", positive=True),
        gain_tolerance=rd.number("pmr.gain_tolerance", positive=True),
        tau_index_threshold=rd.number("pmr.tau_index_threshold", positive=True),
        max_delay_samples=rd.number("pmr.max_delay_samples", integer=True, positive=True),
        coherence_min=rd.number("pmr.coherence_min", positive=True),
    )
    if pmr.coherence_min >= 1.0:
        raise rd.error("pmr.coherence_min", pmr.coherence_min, "must be < 1")
    if pmr.overlap >= 1.0:
        raise rd.error("pmr.overlap", pmr.overlap, "must be < 1")
    if pmr.tau_band > math.pi:
        raise rd.error("pmr.tau_band", pmr.tau_band, "must be <= pi rad/sample")
    try:
        from scipy.signal import get_window

        get_window(pmr.window, 8)
    except ValueError:
        raise rd.error("pmr.window", pmr.window, "not a scipy.signal window name (e.g. hann, hamming, blackman)") from None
    level = rd.number("parametric.confidence_level", positive=True)
    if level >= 1.0:
        raise rd.error("parametric.confidence_level", level, "must be < 1")
    delay_confidence = rd.number("parametric.delay_confidence_min", positive=True)
    if delay_confidence > 1.0:
        raise rd.error("parametric.delay_confidence_min", delay_confidence, "must be <= 1")
    parametric = ParametricSettings(
        segment_length=rd.number("parametric.segment_length", integer=True, minimum=0),
        resolution=rd.number("parametric.resolution", positive=True),
        confidence_level=level,
        gain_tolerance_pct=rd.number("parametric.gain_tolerance_pct", minimum=0.0),
        tau_tolerance_pct=rd.number("parametric.tau_tolerance_pct", minimum=0.0),
        max_interval_pct=rd.number("parametric.max_interval_pct", positive=True),
        delay_confidence_min=delay_confidence,
        coherence_min=rd.number("parametric.coherence_min", minimum=0.0),
        excitation_min=rd.number("parametric.excitation_min", minimum=0.0),
        max_condition=rd.number("parametric.max_condition", positive=True),
        row_time_constant_ratio_warn=rd.number("parametric.row_time_constant_ratio_warn", positive=True),
    )
    if 0 < parametric.segment_length < 16:
        raise rd.error("parametric.segment_length", parametric.segment_length, "must be 0 (automatic) or >= 16")
    run = RunSettings(
        samples=rd.number("run.samples", integer=True, positive=True),
        seed=rd.number("run.seed", integer=True, minimum=0),
        scenario=rd.text("run.scenario", SCENARIOS),
    )
    return PmrConfig(model, mismatch, noise, prbs, mpc, pmr, parametric, run, str(source), params)


def _has(params: dict, field: str) -> bool:
    node: Any = params
    for part in field.split("."):
        if not isinstance(node, dict) or part not in node:
            return False
        node = node[part]
    return True


def load_config(path: str | Path | None = None, overrides: dict | None = None) -> PmrConfig:
    """Load a configuration file laid over the shipped defaults.

    Parameters
    ----------
    path : str or Path, optional
        A ROS 2 params file; default: the shipped Wood-Berry column.
    overrides : dict, optional
        Nested values applied last (e.g. from command-line options).

    Raises
    ------
    ConfigError
        With the file, field and value that are wrong.
    """
    defaults_path = config_dir() / DEFAULTS_FILE
    path = Path(path) if path is not None else config_dir() / DEFAULT_SYSTEM
    params = _merge(read_parameter_file(defaults_path), read_parameter_file(path))
    if overrides:
        params = _merge(params, overrides)
    return parse_config(params, path)
