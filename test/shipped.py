"""Text of the shipped configurations for tests that write params files (config/ stays their one source)."""

from __future__ import annotations

from pathlib import Path

import yaml

from pmr_ros.config import config_dir


def system_only_params(name: str = "wood_berry.yaml") -> str:
    """A params file holding only the ``system`` block of the shipped ``name``.

    Blocks indented by four spaces may be appended (they join ``ros__parameters``).
    """
    tree = yaml.safe_load((config_dir() / name).read_text())
    system = tree["/**"]["ros__parameters"]["system"]
    return yaml.safe_dump({"/**": {"ros__parameters": {"system": system}}}, default_flow_style=None, sort_keys=False)


def without_impact(folder: Path, source: str | Path | None = None) -> Path:
    """``source`` (default the shipped Wood-Berry) as a params file in ``folder`` with ``impact.samples: 0``.

    For node-set tests that check no control impact: a verdict with a mismatch costs the diagnostician 9-11
    closed-loop simulations of 4,096 samples for it (test_nodes, test_live_update and test_update check the impact).
    """
    return with_impact_samples(folder, 0, source, "without_impact.yaml")


def with_impact_samples(folder: Path, samples: int, source: str | Path | None = None, name: str = "") -> Path:
    """``source`` (default the shipped Wood-Berry) as a params file in ``folder`` with ``impact.samples: samples``.

    Short impact simulations serve tests that compare the node set's impact with the batch's (equal at any length).
    """
    doc = yaml.safe_load((Path(source) if source else config_dir() / "wood_berry.yaml").read_text())
    doc["/**"]["ros__parameters"]["impact"] = {"samples": samples}
    out = folder / (name or f"impact_{samples}.yaml")
    out.write_text(yaml.safe_dump(doc, sort_keys=False))
    return out
