"""The topic contract of msg_defs/: names, types, QoS and field documentation."""

from __future__ import annotations

import copy

import pytest
import rclpy  # noqa: F401  # the ROS 2 wheels are part of the set-up (test.sh): missing is an error, not a skip

from pmr_ros.contract.topics import (  # noqa: E402
    PROGRESS_KEY,
    ContractError,
    check_namespace,
    load_contract,
    msg_defs_dir,
    namespaces_of,
    parse_contract,
    resolve_name,
    topic,
)
from pmr_ros.ros.messages import message_class, qos_profile  # noqa: E402

KEYS = ("setpoint", "measured_output", "manipulated_input", "clock", "diagnostics", "estimates")


def test_msg_defs_dir_is_the_source_tree():
    assert (msg_defs_dir() / "topics.yaml").is_file()
    assert (msg_defs_dir() / "README.md").is_file()


def test_contract_lists_every_topic_with_type_qos_and_fields():
    topics = load_contract()
    assert set(KEYS) <= set(topics)
    assert topic("diagnostics").resolved() == "/diagnostics" and topic("diagnostics").name == "diagnostics"
    assert topic("clock").resolved() == "/clock" and topic("clock").resolved("/column_a") == "/column_a/clock"
    for key in KEYS:
        t = topics[key]
        cls = message_class(t)
        assert cls.__name__ == t.type.split("/")[-1]
        profile = qos_profile(t.qos)
        assert profile.depth == t.qos.depth
        assert profile.history.name == t.qos.history.upper() and profile.reliability.name == t.qos.reliability.upper()
        assert t.fields and t.description
    for key in ("setpoint", "measured_output", "manipulated_input"):
        assert topics[key].type == "sensor_msgs/msg/JointState"
        assert "header.stamp" in topics[key].fields


def test_parse_contract_rejects_malformed_entries():
    good = {
        "topics": {
            "x": {
                "name": "/x",
                "type": "std_msgs/msg/Float64",
                "qos": {"reliability": "reliable", "durability": "volatile", "depth": 1},
                "description": "d",
                "fields": {"data": "value"},
            }
        }
    }
    assert parse_contract(good)["x"].qos.depth == 1
    cases = [
        (("name",), "", "must be a topic name"),
        (("name",), "~/private", "must be a topic name"),
        (("qos", "history"), "keep_some", "history"),
        (("type",), "std_msgs/Float64", "package/msg/Type"),
        (("qos", "reliability"), "sometimes", "reliability"),
        (("qos", "durability"), "forever", "durability"),
        (("qos", "depth"), 0, "depth"),
        (("fields",), {}, "document every field"),
    ]
    for path, value, words in cases:
        doc = copy.deepcopy(good)
        node = doc["topics"]["x"]
        for part in path[:-1]:
            node = node[part]
        node[path[-1]] = value
        with pytest.raises(ContractError, match=words):
            parse_contract(doc)
    doc = copy.deepcopy(good)
    del doc["topics"]["x"]["qos"]
    with pytest.raises(ContractError, match="topics.x.qos: missing"):
        parse_contract(doc)
    with pytest.raises(ContractError, match="'topics' mapping"):
        parse_contract({"nope": 1})


def test_unknown_topic_key_is_a_clear_error():
    with pytest.raises(ContractError, match="no topic 'nope'"):
        topic("nope")


def test_rclpy_and_rosbags_qos_come_from_one_mapping():
    from pmr_ros.bag.storage import rosbags_qos

    for t in load_contract().values():
        profile, recorded = qos_profile(t.qos), rosbags_qos(t.qos)
        assert profile.history.name == recorded.history.name
        assert profile.reliability.name == recorded.reliability.name
        assert profile.durability.name == recorded.durability.name
        assert profile.depth == recorded.depth == t.qos.depth


def test_topic_names_are_relative_and_resolve_in_a_namespace():
    for key, t in load_contract().items():
        assert not t.name.startswith("/"), key  # -r __ns:=/column_a moves every topic of a node set
    assert topic("setpoint").resolved() == "/pmr/setpoint"
    assert topic("setpoint").resolved("/column_a") == "/column_a/pmr/setpoint"
    assert topic("setpoint").in_namespace("plant/column_a/").name == "/plant/column_a/pmr/setpoint"
    assert resolve_name("/clock", "/column_a") == "/clock" and resolve_name("pmr/x", "/") == "/pmr/x"
    assert topic(PROGRESS_KEY).type == "std_msgs/msg/Header" and topic(PROGRESS_KEY).qos.reliability == "reliable"


def test_namespaces_are_checked_and_found_in_topic_lists():
    assert check_namespace("column_a") == "/column_a" and check_namespace("/plant/b_2/") == "/plant/b_2"
    assert check_namespace("/") == "/"
    for bad in ("9column", "col-a", "col a", "colümn"):
        with pytest.raises(ContractError, match="not a valid name"):
            check_namespace(bad)
    names = ["/pmr/setpoint", "/column_a/pmr/setpoint", "/column_a/pmr/measured_output", "/other/setpoint_x"]
    assert namespaces_of("setpoint", names) == ["/", "/column_a"]
    assert namespaces_of("setpoint", ["/clock"]) == []
