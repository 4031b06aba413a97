"""config/diagnostic_analyzers.yaml groups every status the diagnostician publishes, as the aggregator matches them.

The aggregator's GenericAnalyzer takes a status when its name equals a ``name``
or ``expected`` entry, starts with a ``startswith`` entry, contains a
``contains`` entry or fully matches a ``regex`` (diagnostic_aggregator's
generic_analyzer.cpp); the test applies those rules to the names a running
diagnostician publishes for Wood-Berry and for the 4x8 debutanizer.
"""

from __future__ import annotations

import re

import pytest
import yaml

from pmr_ros.config import config_dir, flatten_parameters, load_config
from pmr_ros.contract.status_names import SUMMARY, split_status_name, status_name, status_prefix

ANALYZERS = "diagnostic_analyzers.yaml"
GENERIC = "diagnostic_aggregator/GenericAnalyzer"


def _analyzers() -> dict[str, dict]:
    tree = yaml.safe_load((config_dir() / ANALYZERS).read_text())
    params = tree["analyzers"]["ros__parameters"]
    return {name: spec for name, spec in params.items() if isinstance(spec, dict)}


def _matches(spec: dict, name: str) -> bool:
    """GenericAnalyzer::match of the aggregator."""
    return (
        name in spec.get("name", []) + spec.get("expected", [])
        or any(name.startswith(s) for s in spec.get("startswith", []))
        or any(s in name for s in spec.get("contains", []))
        or any(re.fullmatch(r, name) for r in spec.get("regex", []))
    )


def _grouped(name: str) -> list[tuple[str, str]]:
    """``(analyzer, name shown under its path)`` of every analyzer that takes status ``name``."""
    out = []
    for key, spec in _analyzers().items():
        if _matches(spec, name):
            shown = next((name[len(p) :] for p in spec.get("remove_prefix", []) if name.startswith(p)), name)
            out.append((key, shown))
    return out


def _shipped_systems() -> list[str]:
    skip = {"parameters.yaml", ANALYZERS}
    return sorted(p.name for p in config_dir().glob("*.yaml") if p.name not in skip)


def test_every_analyzer_is_a_generic_analyzer_with_a_path_and_a_rule():
    analyzers = _analyzers()
    assert analyzers
    for key, spec in analyzers.items():
        assert spec["type"] == GENERIC, key
        assert spec["path"], key
        assert any(spec.get(rule) for rule in ("startswith", "contains", "name", "expected", "regex")), key
        assert all(
            isinstance(v, str) for rule in ("startswith", "contains", "remove_prefix") for v in spec.get(rule, [])
        )
    assert len({spec["path"] for spec in analyzers.values()}) == len(analyzers)


@pytest.mark.parametrize("file", _shipped_systems())
def test_each_shipped_system_has_exactly_one_group(file):
    config = load_config(config_dir() / file)
    prefix = status_prefix(config.model.name)
    for element in [*config.model.element_names(), SUMMARY]:
        groups = _grouped(status_name(prefix, element))
        assert len(groups) == 1 and groups[0][1] == element, (file, element, groups)


def test_a_status_of_another_system_or_namespace_is_in_no_group():
    assert _grouped("pmr/my_own_loop/G11") == []
    assert _grouped("pmr/column_a/wood_berry/G11") == []  # a namespaced set needs its own analyzer
    assert split_status_name("pmr/column_a/wood_berry/G11") == ("pmr/column_a/wood_berry", "G11")


@pytest.mark.ros
@pytest.mark.parametrize("file", ["wood_berry.yaml", "industrial_column.yaml"])
def test_every_status_the_diagnostician_publishes_is_grouped(ros, file):
    """A running diagnostician without data reports STALE: each of its statuses falls in its system's group."""
    pytest.importorskip("rclpy")
    from pmr_ros.contract.topics import topic
    from pmr_ros.nodes.pmr_diagnostician import NODE_NAME, PmrDiagnosticianNode
    from pmr_ros.ros.messages import message_class, qos_profile
    from pmr_ros.ros.parameters import node_parameters, parameter_overrides

    config = load_config(config_dir() / file)
    declared = {p.name for p in node_parameters(NODE_NAME)}
    flat = {k: v for k, v in flatten_parameters(config.parameters).items() if k in declared}
    flat["diagnostician.stale_timeout_s"] = 0.4
    received = []
    listener = ros.create_node("listener")
    t = topic("diagnostics")
    listener.create_subscription(message_class(t), t.name, received.append, qos_profile(t.qos))
    ros.add(PmrDiagnosticianNode(context=ros.context, parameter_overrides=parameter_overrides(flat)))
    assert ros.spin_until(lambda: bool(received), 20.0), "no /diagnostics from the diagnostician"
    names = [s.name for s in received[-1].status]
    expected = [*config.model.element_names(), SUMMARY]
    assert [n.rsplit("/", 1)[1] for n in names] == expected
    key = file.removesuffix(".yaml") if file == "wood_berry.yaml" else "debutanizer"
    assert all(_grouped(n) == [(key, n.rsplit("/", 1)[1])] for n in names), names
