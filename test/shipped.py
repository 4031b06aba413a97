"""Text of the shipped configurations for tests that write params files (config/ stays their one source)."""

from __future__ import annotations

import yaml

from pmr_ros.config import config_dir


def system_only_params(name: str = "wood_berry.yaml") -> str:
    """A params file holding only the ``system`` block of the shipped ``name``.

    Blocks indented by four spaces may be appended (they join ``ros__parameters``).
    """
    tree = yaml.safe_load((config_dir() / name).read_text())
    system = tree["/**"]["ros__parameters"]["system"]
    return yaml.safe_dump({"/**": {"ros__parameters": {"system": system}}}, default_flow_style=None, sort_keys=False)
