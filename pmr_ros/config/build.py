"""From a parameter tree to the core's typed settings, strictly.

Every key must be declared in ``config/parameters.yaml`` (a typo is an error
that names the nearest known key), every block must be a mapping, every value
is checked against its declaration, and what a file leaves out takes the
declared default -- except the ``system`` block, which has none: the
shipped Wood-Berry column never stands in for a plant model.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from ..core.loop.adaptation import AdaptSettings
from ..core.loop.impact import ImpactSettings
from ..core.mpc.controller import MpcTuning
from ..core.pmr.classic import PmrSettings
from ..core.pmr.data_quality import QualitySettings
from ..core.pmr.parametric import ParametricSettings
from ..core.sim.excitation import ExcitationSettings
from ..core.sim.model import Mismatch, TransferMatrix
from ..core.sim.true_plant import OutputDisturbance
from .controller_block import controller_settings
from .data import DATA_BLOCK, DataSettings, check_data_settings, data_settings, with_time_unit
from .errors import ConfigError
from .general_elements import GENERAL_KINDS, block_elements, block_numbers
from .plant_block import plant_block
from .pmr_config import DiagnosticianSettings, PmrConfig, RunSettings, SimulationSettings
from .prbs_block import check_prbs_channels, prbs_settings
from .routine import (
    disturbance_mismatch,
    disturbance_names,
    disturbance_signal,
    manual_settings,
    zone_settings,
)
from .schema import Shape, blocks, closest_name, default_tree, element_label, parameter, parameters

__all__ = ["check_tree", "parse_config"]

SYSTEM_BLOCK = "system"
PLANT_BLOCK = "plant"
PLANT_DISTURBANCE_KEYS = {"disturbance_gain", "disturbance_numerator", "disturbance_element_type"}
"""Any of them gives the plant block its own DV elements (else they are the model's)."""


def _did_you_mean(name: str, known: list[str]) -> str:
    guess = closest_name(name, known)
    return f"; did you mean {guess}?" if guess else ""


def check_tree(tree: Any, source: str) -> dict[str, dict[str, Any]]:
    """Check a parameter tree's shape and names against the declaration.

    Raises
    ------
    ConfigError
        The tree is not a mapping of blocks, a block is not a mapping, or a
        block or parameter is not declared (with the nearest known name).
    """
    if not isinstance(tree, Mapping):
        raise ConfigError(source, "ros__parameters", tree, "must be a mapping of parameter blocks")
    known_blocks = blocks()
    for block, values in tree.items():
        if block not in known_blocks:
            guess = _did_you_mean(str(block), [*known_blocks, *parameters()])
            raise ConfigError(source, str(block), None, f"unknown block (known: {', '.join(known_blocks)}){guess}")
        if not isinstance(values, Mapping):
            names = ", ".join(p.name for p in known_blocks[block].parameters[:3])
            raise ConfigError(
                source,
                str(block),
                values,
                f"must be a mapping of parameters ({names}, ...), not a {type(values).__name__}",
            )
        declared = [p.name for p in known_blocks[block].parameters]
        for key in values:
            name = f"{block}.{key}"
            if name not in declared:
                raise ConfigError(
                    source,
                    name,
                    None,
                    f"unknown parameter{_did_you_mean(name, declared) or _did_you_mean(name, list(parameters()))}",
                )
    return {str(block): dict(values) for block, values in tree.items()}


def _effective(tree: dict[str, dict[str, Any]]) -> dict[str, dict[str, Any]]:
    """Declared defaults with the tree's values laid over them."""
    out = default_tree()
    for block, values in tree.items():
        out.setdefault(block, {}).update(values)
    return out


class _Values:
    """Checked access to the effective tree's values, naming each value's source."""

    def __init__(
        self,
        tree: dict[str, dict[str, Any]],
        source: str,
        sources: Mapping[str, str],
        curve_sets: Mapping[str, Any] | None = None,
    ) -> None:
        self.tree, self.source, self.sources = tree, source, sources
        self.curve_sets = curve_sets or {}
        self.shape: Shape | None = None
        self.warnings: list[str] = []
        self.plant_keys = frozenset(tree.get(PLANT_BLOCK, {}))  # as given: the optional block has no defaults

    def raw(self, name: str) -> Any:
        block, key = name.split(".", 1)
        if key not in self.tree.get(block, {}):
            raise ConfigError(self.source, name, None, f"missing ({parameter(name).doc})")
        return self.tree[block][key]

    def source_of(self, name: str) -> str:
        return self.sources.get(name, self.source)

    def __getitem__(self, name: str) -> Any:
        return parameter(name).check(self.raw(name), source=self.source_of(name), shape=self.shape)

    def error(self, name: str, value: Any, reason: str) -> ConfigError:
        return ConfigError(self.source_of(name), name, value, reason)


def _model(v: _Values) -> TransferMatrix:
    given = v.tree.get(SYSTEM_BLOCK, {})
    if not any(p.name.split(".", 1)[1] in given for p in blocks()[SYSTEM_BLOCK].parameters if p.required):
        raise ConfigError(
            v.source,
            SYSTEM_BLOCK,
            None,
            "missing: a configuration needs the controller's model (system: sample_time, output_names, input_names, "
            "gain, time_constant, delay)",
        )
    outputs, inputs = v["system.output_names"], v["system.input_names"]
    v.shape = Shape(len(outputs), len(inputs), len(disturbance_names(v, inputs)))
    _ = [v[f"system.{key}"] for key in ("output_units", "input_units", "disturbance_units", "time_unit")]  # checked
    return _matrix(v, SYSTEM_BLOCK, outputs=outputs, inputs=inputs, name=v["system.name"])


def _check_elements(
    v: _Values, block: str, kinds: np.ndarray, gain: np.ndarray, tau: np.ndarray, *, prefix: str
) -> None:
    """Per element type: a non-zero gain, a positive FOPTD time constant; warn of an integrating one's ignored tau.

    A tf or step_response element's gain is its own (the field is ignored, may be 0).
    """
    shape, per = v.shape, "disturbance_elements" if prefix else ""
    label = (lambda j: element_label(j, shape, per)) if shape is not None else (lambda j: "")
    flat_kinds, g, t = kinds.ravel(), gain.ravel(), tau.ravel()
    zero_gain = np.flatnonzero(np.isin(flat_kinds, ("foptd", "integrating")) & (g == 0))
    bad_tau = np.flatnonzero((flat_kinds == "foptd") & (t <= 0))
    if zero_gain.size and (not bad_tau.size or zero_gain[0] <= bad_tau[0]):
        j = int(zero_gain[0])
        raise v.error(
            f"{block}.{prefix}gain[{j}] ({label(j)})", 0.0, "must be non-zero: use element_type none for an empty cell"
        )
    if bad_tau.size:
        j = int(bad_tau[0])
        raise v.error(f"{block}.{prefix}time_constant[{j}] ({label(j)})", float(t[j]), "must be > 0")
    for j in np.flatnonzero((flat_kinds == "integrating") & (t > 0)).tolist():
        v.warnings.append(
            f"{v.source_of(f'{block}.{prefix}time_constant')}: {block}.{prefix}time_constant[{j}] ({label(j)}) = "
            f"{t[j]:g} is ignored: {label(j)} is integrating"
        )


def _matrix(
    v: _Values, block: str, *, outputs: tuple[str, ...], inputs: tuple[str, ...], name: str, prefix: str = ""
) -> TransferMatrix:
    """The elements of ``block`` (``system`` or ``plant``) as a :class:`TransferMatrix`, checked per element type.

    ``prefix="disturbance_"``: the block's DV elements (``disturbance_gain``, ...), n_outputs x n_disturbances.
    """
    ts = v["system.sample_time"]
    per = "disturbance_elements" if prefix else ""
    shape = v.shape
    label = (lambda j: element_label(j, shape, per)) if shape is not None else (lambda j: "")
    kinds = v[f"{block}.{prefix}element_type"]
    general = bool(np.isin(kinds, GENERAL_KINDS).any())
    gain, tau = (
        block_numbers(v, f"{block}.{prefix}gain", kinds),
        block_numbers(v, f"{block}.{prefix}time_constant", kinds),
    )
    delay = v[f"{block}.{prefix}delay"]
    _check_elements(v, block, kinds, gain, tau, prefix=prefix)
    whole = np.where(kinds == "none", 0.0, delay / ts)
    bad = np.flatnonzero(np.abs(whole - np.rint(whole)).ravel() > 1e-9 * np.maximum(1.0, np.abs(whole).ravel()))
    if bad.size:
        j = int(bad[0])
        raise v.error(
            f"{block}.{prefix}delay[{j}] ({label(j)})",
            float(delay.ravel()[j]),
            f"must be a whole number of samples (sample_time = {ts:g})",
        )
    if general:
        return block_elements(
            v,
            block,
            {"element_type": kinds, "gain": gain, "time_constant": tau, "delay": delay},
            names=(outputs, inputs, name),
            prefix=prefix,
        )
    return TransferMatrix(gain, tau, np.rint(whole) * ts, ts, outputs, inputs, name, element_type=kinds)


def _explicit_plant(v: _Values, model: TransferMatrix, given: Mapping[str, Any]) -> TransferMatrix | None:
    """The ``plant`` block, if given; it excludes a ``mismatch`` block and a ``run.scenario``."""
    if not {"gain", "numerator", "model_file"} & set(v.tree.get(PLANT_BLOCK, {})):
        return None
    for clash in ("mismatch", "run.scenario"):
        block, _, key = clash.partition(".")
        if block in given and (not key or key in given[block]):
            raise v.error(
                clash, None, "cannot be given with a plant block: the plant block is the true plant of the run"
            )
    plant_block(v.tree[PLANT_BLOCK], model, error=v.error, disturbance_names=disturbance_names(v, model.input_names))
    name = v[f"{PLANT_BLOCK}.name"] or model.name
    return _matrix(v, PLANT_BLOCK, outputs=model.output_names, inputs=model.input_names, name=name)


def _disturbance_model(v: _Values, model: TransferMatrix, block: str = SYSTEM_BLOCK) -> TransferMatrix | None:
    """The DV elements of ``block`` (the feedforward model, or the plant's true ones); None without DVs."""
    names = disturbance_names(v, model.input_names)
    if not names or (block == PLANT_BLOCK and not PLANT_DISTURBANCE_KEYS & v.plant_keys):
        return None
    if block == PLANT_BLOCK:
        plant_block(v.tree[PLANT_BLOCK], model, error=v.error, disturbance_names=names)
    return _matrix(v, block, outputs=model.output_names, inputs=names, name=model.name, prefix="disturbance_")


def _mismatch(v: _Values, model: TransferMatrix) -> Mismatch:
    delay = v["mismatch.delay_samples"]
    if np.any(model.delay_samples + delay < 0):
        raise v.error("mismatch.delay_samples", delay.ravel().tolist(), "would make a plant delay negative")
    return Mismatch(v["mismatch.gain_pct"], v["mismatch.time_constant_pct"], np.rint(delay).astype(int))


def _mpc(v: _Values, model: TransferMatrix) -> MpcTuning:
    np_h, nc_h = v["mpc.prediction_horizon"], v["mpc.control_horizon"]
    if nc_h > np_h:
        raise v.error("mpc.control_horizon", nc_h, f"must not exceed mpc.prediction_horizon ({np_h})")
    if np_h <= int(model.delay_samples.max()):
        raise v.error(
            "mpc.prediction_horizon", np_h, f"must exceed the largest delay ({int(model.delay_samples.max())} samples)"
        )
    u_min, u_max = v["mpc.u_min"], v["mpc.u_max"]
    if np.any(u_min >= u_max):
        raise v.error("mpc.u_min", u_min.tolist(), "must be below mpc.u_max")
    target = v["mpc.input_target"]
    if np.any((target < u_min) | (target > u_max)):
        raise v.error("mpc.input_target", target.tolist(), "must lie within mpc.u_min .. mpc.u_max")
    return MpcTuning(
        prediction_horizon=np_h,
        control_horizon=nc_h,
        output_weight=v["mpc.output_weight"],
        move_weight=v["mpc.move_weight"],
        u_min=u_min,
        u_max=u_max,
        du_max=v["mpc.du_max"],
        input_target=target,
        input_target_weight=v["mpc.input_target_weight"],
        ramp_filter_samples=v["mpc.ramp_filter_samples"],
        **zone_settings(v, model.output_names),
    )


def _pmr(v: _Values) -> PmrSettings:
    window = v["pmr.window"]
    try:
        from scipy.signal import get_window

        get_window(window, 8)
    except ValueError:
        raise v.error("pmr.window", window, "not a scipy.signal window name (e.g. hann, hamming, blackman)") from None
    keys = (
        "method",
        "window",
        "segment_length",
        "overlap",
        "tau_band",
        "gain_tolerance",
        "tau_index_threshold",
        "max_delay_samples",
        "coherence_min",
        "delay_fit_min",
    )
    return PmrSettings(**{key: v[f"pmr.{key}"] for key in keys})


def _parametric(v: _Values) -> ParametricSettings:
    keys = [f.split(".", 1)[1] for f in parameters() if f.startswith("parametric.")]
    settings = ParametricSettings(**{key: v[f"parametric.{key}"] for key in keys})
    if 0 < settings.segment_length < 16:
        raise v.error("parametric.segment_length", settings.segment_length, "must be 0 (automatic) or >= 16")
    return settings


def _quality(v: _Values, mpc: MpcTuning) -> QualitySettings:
    keys = [f.split(".", 1)[1] for f in parameters() if f.startswith("quality.")]
    return QualitySettings(u_min=mpc.u_min, u_max=mpc.u_max, **{key: v[f"quality.{key}"] for key in keys})


def _diagnostician(v: _Values) -> DiagnosticianSettings:
    keys = [f.split(".", 1)[1] for f in parameters() if f.startswith("diagnostician.")]
    settings = DiagnosticianSettings(**{key: v[f"diagnostician.{key}"] for key in keys})
    if settings.min_samples > settings.window_samples:
        raise v.error(
            "diagnostician.min_samples",
            settings.min_samples,
            f"must not exceed diagnostician.window_samples ({settings.window_samples})",
        )
    return settings


def _data(v: _Values, model: TransferMatrix, given: Mapping[str, Any]) -> DataSettings:
    data = data_settings(v.__getitem__, [f.split(".", 1)[1] for f in parameters() if f.startswith("data.")])
    data = with_time_unit(data, v["system.time_unit"], given="time_unit_s" in given.get("data", {}), error=v.error)
    v.tree[DATA_BLOCK]["time_unit_s"] = data.time_unit_s  # the effective tree says it too (a file written from it)
    v.warnings.extend(check_data_settings(data, v.tree, output_names=model.output_names, source_of=v.source_of))
    return data


def _simulation(v: _Values) -> SimulationSettings:
    keys = [f.split(".", 1)[1] for f in parameters() if f.startswith("simulation.")]
    return SimulationSettings(**{key: v[f"simulation.{key}"] for key in keys})


def parse_config(
    tree: Any, source: str, *, sources: Mapping[str, str] | None = None, curves: Mapping[str, Any] | None = None
) -> PmrConfig:
    """Validate a nested parameter tree into a :class:`PmrConfig`.

    Parameters
    ----------
    tree : mapping
        ``ros__parameters`` of a params file (or a node's parameters, nested).
    source : str
        Named in error messages (the file).
    sources : mapping, optional
        Dotted name to another source of that value (e.g. ``command line (--seed)``).
    curves : mapping, optional
        ``system.model_file`` / ``plant.model_file`` to the :class:`~pmr_ros.models.CurveSet`
        of that file, read already (a bag's embedded copy): the file itself is not read.

    Raises
    ------
    ConfigError
        One line naming the source, the field and the value.
    """
    source = str(source)
    checked = check_tree(tree, source)
    v = _Values(_effective(checked), source, sources or {}, curves)
    model = _model(v)
    excitation = ExcitationSettings(v["excitation.mv_dither_amplitude"], v["excitation.mv_dither_clock_period"])
    check_prbs_channels(v, model, excitation)
    mpc = _mpc(v, model)
    dv_model = _disturbance_model(v, model)
    return PmrConfig(
        model=model,
        mismatch=_mismatch(v, model),
        noise_std=v["noise.std"],
        disturbance=OutputDisturbance(v["noise.disturbance_std"], v["noise.disturbance_pole"]),
        prbs=prbs_settings(v),
        excitation=excitation,
        mpc=mpc,
        pmr=_pmr(v),
        parametric=_parametric(v),
        quality=_quality(v, mpc),
        run=RunSettings(samples=v["run.samples"], seed=v["run.seed"], scenario=v["run.scenario"]),
        simulation=_simulation(v),
        diagnostician=_diagnostician(v),
        impact=ImpactSettings(samples=v["impact.samples"]),
        adapt=AdaptSettings(ise_rise_tolerance_pct=v["adapt.ise_rise_tolerance_pct"]),
        data=_data(v, model, checked),
        source=source,
        parameters=v.tree,
        explicit_plant=_explicit_plant(v, model, checked),
        disturbance_model=dv_model,
        disturbance_mismatch=None if dv_model is None else disturbance_mismatch(v, dv_model),
        explicit_disturbance_plant=None if dv_model is None else _disturbance_model(v, model, PLANT_BLOCK),
        disturbance_signal=disturbance_signal(v),
        manual=manual_settings(v, model.input_names),
        controller=controller_settings(v, checked.get("controller", {}), model),
        warnings=tuple(v.warnings),
        given=frozenset(f"{block}.{key}" for block, values in checked.items() for key in values),
    )
