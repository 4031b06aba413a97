"""Duplicate keys and alias bombs are refused in one line, wherever pmr_ros reads YAML (issue 21, items 2 and 6)."""

from __future__ import annotations

import time
import tracemalloc

import pytest
import yaml

from pmr_ros.cli import main
from pmr_ros.config import ConfigError, config_dir, load_config
from pmr_ros.config.fast_yaml import LARGE_TEXT, load
from pmr_ros.config.yaml_guard import ALIAS_EXPANSION_LIMIT, DocumentError, check_document, expanded_size
from pmr_ros.contract.model_topics import read_active_model, system_parameters
from pmr_ros.nodes.pmr_diagnostician import main as diagnostician_main

WOOD_BERRY = (config_dir() / "wood_berry.yaml").read_text()


def _bomb(levels: int = 9, indent: str = "") -> str:
    """``levels`` lines of nine aliases each: 9**levels strings once expanded, about 1 KB written."""
    lines = [f'{indent}a0: &a0 ["lol", "lol", "lol", "lol", "lol", "lol", "lol", "lol", "lol"]']
    lines += [f"{indent}a{i}: &a{i} [{', '.join([f'*a{i - 1}'] * 9)}]" for i in range(1, levels)]
    return "\n".join(lines) + "\n"


def _with_line(text: str, after: str, line: str) -> tuple[str, int]:
    """``text`` with ``line`` inserted after the first line starting with ``after``; the new line's number."""
    lines = text.splitlines()
    at = next(i for i, x in enumerate(lines) if x.strip().startswith(after)) + 1
    lines.insert(at, line)
    return "\n".join(lines) + "\n", at + 1


def test_a_second_gain_line_is_an_error_naming_both_lines(tmp_path):
    first = next(i for i, x in enumerate(WOOD_BERRY.splitlines(), 1) if x.strip().startswith("gain:"))
    text, second = _with_line(WOOD_BERRY, "gain:", "      gain: [1.0, 1.0, 1.0, 1.0]")
    path = tmp_path / "twice.yaml"
    path.write_text(text)
    with pytest.raises(ConfigError) as err:
        load_config(path)
    message = str(err.value)
    assert "system.gain" in message and "duplicate key" in message
    assert f"{path}:{first} and {path}:{second}" in message
    assert "\n" not in message


def test_a_second_block_is_an_error_on_the_cli(tmp_path, capsys):
    text = WOOD_BERRY + "    mismatch:\n      gain_pct: [0.0, 0.0, 0.0, 0.0]\n"  # cancels the file's scenario
    path = tmp_path / "blocks.yaml"
    path.write_text(text)
    lines = text.splitlines()
    first, second = (i for i, x in enumerate(lines, 1) if x.strip() == "mismatch:")
    assert main(["run", "--batch", "--config", str(path), "--samples", "512"]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "Traceback" not in err
    assert "mismatch: duplicate key" in err and f"{path}:{first} and {path}:{second}" in err


def test_a_duplicate_in_a_large_file_is_found_on_the_fast_path():
    pad = "[" + ", ".join(["1.5"] * (LARGE_TEXT // 4)) + "]"
    text = f"x: {pad}\ny: 1\nx: 2\n"
    assert len(text) > LARGE_TEXT
    with pytest.raises(DocumentError) as err:
        load(text)
    assert err.value.field == "x" and err.value.lines == (1, 3)


def test_merge_keys_and_equal_keys_in_different_mappings_are_not_duplicates():
    text = "base: &b {gain: 1, delay: 2}\nx:\n  <<: *b\n  gain: 3\ny: {gain: 4}\n"
    assert load(text) == yaml.safe_load(text)


def test_a_node_refuses_a_params_file_with_a_duplicate_key(tmp_path, capsys):
    text, second = _with_line(WOOD_BERRY, "delay:", "      delay: [0.0, 0.0, 0.0, 0.0]")
    path = tmp_path / "node.yaml"
    path.write_text(text)
    assert diagnostician_main(["pmr_diagnostician", "--ros-args", "--params-file", str(path)]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("pmr_diagnostician: error:") and f"{path}:{second}" in err and "system.delay" in err


def test_a_duplicate_key_in_a_model_message_is_refused():
    text = "first_sample: 0\nrevision: 1\nsystem: {gain: [1]}\nrevision: 2\n"
    with pytest.raises(ConfigError, match=r"/m: revision: duplicate key on lines 2 and 4"):
        read_active_model(text, "/m")


def test_the_alias_bomb_is_measured_not_expanded(tmp_path, capsys):
    """The 1 KB bomb of the probe (9**9 strings) is refused from its ~100 written nodes.

    Speed is shown by what the refusal does, not by a clock: the memory it takes
    is that of the composed document (a few hundred KB), far below even one
    expanded level, and the count it reports is computed, never built.
    """
    path = tmp_path / "bomb.yaml"
    path.write_text(WOOD_BERRY + _bomb(indent="    "))
    assert len(_bomb()) < 1100
    tracemalloc.start()
    started = time.perf_counter()
    with pytest.raises(ConfigError) as err:
        load_config(path)
    took = time.perf_counter() - started
    _, peak = tracemalloc.get_traced_memory()
    tracemalloc.stop()
    assert "alias bomb" in str(err.value) and "\n" not in str(err.value)
    expanded, distinct = expanded_size(yaml.compose(_bomb()))
    assert distinct < 200 and expanded > 9**9 > ALIAS_EXPANSION_LIMIT
    assert peak < 5_000_000, f"the refusal took {peak / 1e6:.1f} MB"
    print(f"alias bomb refused in {took * 1e3:.0f} ms, peak {peak / 1e6:.2f} MB")  # measured, shown with -s
    assert main(["run", "--batch", "--config", str(path), "--samples", "512"]) == 2
    assert "alias bomb" in capsys.readouterr().err


def test_the_alias_bomb_in_a_model_message_is_one_line():
    text = _bomb() + "system: *a8\nfirst_sample: 0\nrevision: 1\n"
    with pytest.raises(ConfigError) as err:
        read_active_model(text, "/pmr/active_model")
    assert str(err.value).startswith("/pmr/active_model: <message>: aliases expand")
    with pytest.raises(ConfigError, match="alias bomb"):
        system_parameters(_bomb() + "/**: {ros__parameters: {system: *a8}}\n", "/pmr/proposed_model")


def test_a_recursive_alias_and_moderate_aliases():
    with pytest.raises(DocumentError, match="refers to a node containing it"):
        check_document(yaml.compose("a: &x [1, *x]\n"))
    fine = "a: &x [1, 2, 3]\nb: [*x, *x, *x]\n"
    assert load(fine) == yaml.safe_load(fine)
    expanded, distinct = expanded_size(yaml.compose(fine))
    assert (expanded, distinct) == (1 + 2 + 4 + 1 + 3 * 4, 1 + 2 + 4 + 1)  # mapping, keys, [1, 2, 3], [*x, *x, *x]
