"""The model topics' payloads as plain data: the controller's active model and the proposed model.

``pmr/active_model`` (published by ``mpc_controller``, latched) is YAML:
``first_sample`` (the first sample whose input the model computes),
``revision`` (0 at start, one more per switch) and the ``system`` block.
``pmr/proposed_model`` (published by ``pmr_diagnostician``, latched) is a
params file whose ``system`` block is the corrected model
(:func:`pmr_ros.service.closing.model_file_text`).  Both are read back
strictly, through the same validation as a params file.  No ROS imports.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import yaml

from ..config import ConfigError, PmrConfig, flatten_parameters, parse_config
from ..config.fast_yaml import load as load_yaml_text
from ..config.write import system_tree
from ..config.yaml_guard import DocumentError
from ..core.sim.model import TransferMatrix

__all__ = ["ActiveModel", "active_model_text", "read_active_model", "system_parameters", "with_system"]


@dataclass(frozen=True)
class ActiveModel:
    """The controller's model and the first sample it applies to.

    Attributes
    ----------
    first_sample : int
        The first sample k whose u(k) the model computes.
    revision : int
        0 for the model the controller started with, one more per switch.
    system : dict
        The model's ``system`` block (params-file values).
    """

    first_sample: int
    revision: int
    system: dict[str, Any]


def active_model_text(model: TransferMatrix, *, first_sample: int, revision: int, model_file: str = "") -> str:
    """The ``pmr/active_model`` payload of ``model`` (YAML, floats lossless); ``model_file`` its curve file, if any."""
    return yaml.safe_dump(
        {
            "first_sample": int(first_sample),
            "revision": int(revision),
            "system": system_tree(model, model_file=model_file),
        },
        sort_keys=False,
        width=10_000,
    )


def _document(text: str, source: str) -> Any:
    """The YAML document of a message, refused (duplicate key, alias bomb, bad YAML) in one line."""
    try:
        return load_yaml_text(text)
    except DocumentError as exc:
        raise ConfigError(source, exc.field.replace("<file>", "<message>"), None, exc.reason) from None
    except yaml.YAMLError as exc:
        raise ConfigError(source, "<message>", None, f"not valid YAML: {' '.join(str(exc).split())}") from None


def read_active_model(text: str, source: str) -> ActiveModel:
    """Inverse of :func:`active_model_text`.

    Raises
    ------
    ConfigError
        The text is not such a payload (one line naming ``source`` and the field).
    """
    doc = _document(text, source)
    if not isinstance(doc, dict) or not isinstance(doc.get("system"), dict):
        raise ConfigError(source, "system", None, "missing: the active model's system block")
    for key in ("first_sample", "revision"):
        if not isinstance(doc.get(key), int) or isinstance(doc.get(key), bool) or doc[key] < 0:
            raise ConfigError(source, key, doc.get(key), "must be a whole number >= 0")
    return ActiveModel(int(doc["first_sample"]), int(doc["revision"]), dict(doc["system"]))


def system_parameters(text: str, source: str) -> dict[str, Any]:
    """The dotted ``system.*`` values of a params file's text (a proposal), for one atomic parameter change.

    Raises
    ------
    ConfigError
        No params file or no ``system`` block.
    """
    doc = _document(text, source)
    params = doc.get("/**", {}).get("ros__parameters", {}) if isinstance(doc, dict) else {}
    system = params.get("system") if isinstance(params, dict) else None
    if not isinstance(system, dict):
        raise ConfigError(source, "system", None, "missing: a proposed model needs its system block")
    return flatten_parameters({"system": system})


def with_system(config: PmrConfig, system: dict[str, Any], source: str) -> PmrConfig:
    """``config`` with its ``system`` block replaced, validated as a params file would be.

    The measured disturbances' model (``system.disturbance_*``) stays the configuration's.

    Raises
    ------
    ConfigError
        The block is invalid (one line naming ``source`` and the field).
    """
    dvs = {k: v for k, v in config.parameters.get("system", {}).items() if k.startswith("disturbance_")}
    tree = {**config.parameters, "system": {**dvs, **system}}
    return parse_config(tree, source)
