"""Packaging: the version in one place, an installed copy's data folders and executables found.

The install layouts are faked in tmp dirs (a sourced colcon workspace through
``AMENT_PREFIX_PATH``, a pip install through ``sys.prefix``), with the checkout
itself hidden (``pmr_ros.resources.SOURCE_ROOT``) so the lookup cannot fall back
on it.  Real installs are checked by scripts/check_colcon_install.sh and
scripts/check_pip_install.sh (.ci/run).
"""

from __future__ import annotations

import ast
import importlib.metadata
import os
import re
import shutil
import subprocess
import sys
import xml.etree.ElementTree as ElementTree
from pathlib import Path

import pytest
from ros_fixtures import console_script

import pmr_ros
from pmr_ros import _version, resources
from pmr_ros.resources import ResourceError, share_dir

ROOT = Path(__file__).resolve().parents[1]
INDEX_MARKER = Path("share") / "ament_index" / "resource_index" / "packages" / "pmr_ros"


def manifest_version(path: Path) -> str:
    """``<version>`` of a package.xml by a regular expression (not the parser under test)."""
    match = re.search(r"<version>\s*([^<\s]+)\s*</version>", path.read_text())
    assert match, f"{path} has no <version>"
    return match.group(1)


def write_manifest(folder: Path, version: str, name: str = "pmr_ros") -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / "package.xml"
    path.write_text(
        f'<?xml version="1.0"?>\n<package format="3">\n'
        f"  <name>{name}</name>\n  <version>{version}</version>\n</package>\n"
    )
    return path


def fake_prefix(prefix: Path, *, registered: bool = True, marker: str = "wood_berry.yaml") -> Path:
    """An install prefix with ``share/pmr_ros/config/<marker>``, in the ament index or not."""
    config = prefix / "share" / "pmr_ros" / "config"
    config.mkdir(parents=True)
    (config / marker).write_text("# fake\n")
    if registered:
        (prefix / INDEX_MARKER).parent.mkdir(parents=True)
        (prefix / INDEX_MARKER).write_text("")
    return config


@pytest.fixture
def nothing_installed(tmp_path, monkeypatch) -> Path:
    """Every place share_dir looks is empty: no checkout, no sourced workspace, an empty interpreter prefix."""
    monkeypatch.setattr(resources, "SOURCE_ROOT", tmp_path / "site-packages")
    monkeypatch.setattr(sys, "prefix", str(tmp_path / "venv"))
    monkeypatch.setattr(sys, "base_prefix", str(tmp_path / "base"))
    monkeypatch.delenv("AMENT_PREFIX_PATH", raising=False)
    return tmp_path


@pytest.fixture(params=["ament_index_python", "environment only"])
def ament_lookup(request, monkeypatch) -> str:
    """Both ways resources.ament_prefixes reads the index: with ament_index_python, and without (plain pip)."""
    if request.param == "environment only":
        # None in sys.modules makes `import ament_index_python.packages` raise ImportError.
        monkeypatch.setitem(sys.modules, "ament_index_python", None)
        monkeypatch.setitem(sys.modules, "ament_index_python.packages", None)
    return request.param


# -- version -------------------------------------------------------------------


def test_version_is_the_one_in_package_xml():
    assert pmr_ros.__version__ == manifest_version(ROOT / "package.xml")


def test_setup_py_takes_the_version_from_package_xml(tmp_path):
    shutil.copy(ROOT / "setup.py", tmp_path)
    write_manifest(tmp_path, "9.8.7")
    proc = subprocess.run(
        [sys.executable, "setup.py", "--version"], cwd=tmp_path, capture_output=True, text=True, timeout=120
    )
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.strip().splitlines()[-1] == "9.8.7"


def test_version_of_a_checkout_is_its_package_xml(tmp_path, monkeypatch):
    write_manifest(tmp_path, "9.8.7")
    monkeypatch.setattr(resources, "SOURCE_ROOT", tmp_path)
    assert _version.package_version() == "9.8.7"


def test_version_ignores_another_packages_manifest(tmp_path, monkeypatch):
    write_manifest(tmp_path, "9.8.7", name="not_pmr_ros")
    monkeypatch.setattr(resources, "SOURCE_ROOT", tmp_path)
    monkeypatch.setattr(importlib.metadata, "version", lambda name: "5.6.7" if name == "pmr_ros" else "0")
    assert _version.package_version() == "5.6.7"


def test_version_without_metadata_comes_from_the_installed_share(nothing_installed, monkeypatch):
    def no_metadata(name: str) -> str:
        raise importlib.metadata.PackageNotFoundError(name)

    monkeypatch.setattr(importlib.metadata, "version", no_metadata)
    assert _version.package_version() == _version.UNKNOWN_VERSION
    write_manifest(nothing_installed / "venv" / "share" / "pmr_ros", "4.5.6")
    assert _version.package_version() == "4.5.6"


def test_read_package_xml_refuses_a_manifest_without_version(tmp_path):
    path = tmp_path / "package.xml"
    path.write_text("<package format='3'><name>pmr_ros</name></package>")
    with pytest.raises(ValueError, match="no <version>"):
        _version.read_package_xml(path)


# -- data folders ----------------------------------------------------------------


def test_share_dir_finds_a_sourced_colcon_workspace(nothing_installed, ament_lookup, monkeypatch):
    with pytest.raises(ResourceError, match="wood_berry.yaml"):
        share_dir("config", "wood_berry.yaml")
    underlay = nothing_installed / "underlay"
    underlay.mkdir()  # a prefix without pmr_ros before the workspace, as /opt/ros/jazzy would be
    config = fake_prefix(nothing_installed / "ws" / "install" / "pmr_ros")
    monkeypatch.setenv("AMENT_PREFIX_PATH", os.pathsep.join([str(underlay), str(config.parents[2])]))
    assert share_dir("config", "wood_berry.yaml") == config


def test_share_dir_ignores_a_prefix_outside_the_ament_index(nothing_installed, ament_lookup, monkeypatch):
    config = fake_prefix(nothing_installed / "stray", registered=False)
    monkeypatch.setenv("AMENT_PREFIX_PATH", str(config.parents[2]))
    with pytest.raises(ResourceError):
        share_dir("config", "wood_berry.yaml")


def test_share_dir_finds_a_pip_install(nothing_installed):
    config = fake_prefix(nothing_installed / "venv", registered=False)
    assert share_dir("config", "wood_berry.yaml") == config


def test_share_dir_prefers_checkout_then_workspace_then_interpreter(nothing_installed, monkeypatch):
    in_venv = fake_prefix(nothing_installed / "venv", registered=False)
    workspace = fake_prefix(nothing_installed / "ws")
    monkeypatch.setenv("AMENT_PREFIX_PATH", str(workspace.parents[2]))
    checkout = nothing_installed / "site-packages" / "config"
    checkout.mkdir(parents=True)
    (checkout / "wood_berry.yaml").write_text("# fake\n")
    assert share_dir("config", "wood_berry.yaml") == checkout
    shutil.rmtree(checkout)
    assert share_dir("config", "wood_berry.yaml") == workspace
    monkeypatch.delenv("AMENT_PREFIX_PATH")
    assert share_dir("config", "wood_berry.yaml") == in_venv


# -- executables -----------------------------------------------------------------


def executable_file(path: Path, mode: int = 0o755) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text("#!/bin/sh\n")
    path.chmod(mode)
    return path


def test_console_script_prefers_a_sourced_workspace(tmp_path, ament_lookup, monkeypatch):
    # A venv of its own (beside a fake interpreter) and an empty PATH: the result cannot depend on
    # whether this environment has pmr_ros's scripts installed.
    in_venv = executable_file(tmp_path / "venv" / "bin" / "pmr_diagnostician")
    monkeypatch.setattr(sys, "executable", str(tmp_path / "venv" / "bin" / "python"))
    monkeypatch.setenv("PATH", str(tmp_path / "empty"))
    prefix = tmp_path / "install" / "pmr_ros"
    in_workspace = executable_file(prefix / "lib" / "pmr_ros" / "pmr_diagnostician", mode=0o644)
    (prefix / INDEX_MARKER).parent.mkdir(parents=True)
    (prefix / INDEX_MARKER).write_text("")
    monkeypatch.setenv("AMENT_PREFIX_PATH", str(prefix))
    assert console_script("pmr_diagnostician") == str(in_venv)  # the workspace's copy is not executable
    in_workspace.chmod(0o755)
    assert console_script("pmr_diagnostician") == str(in_workspace)
    monkeypatch.delenv("AMENT_PREFIX_PATH")
    assert console_script("pmr_diagnostician") == str(in_venv)


def test_console_script_missing_fails_the_test(monkeypatch):
    monkeypatch.delenv("AMENT_PREFIX_PATH", raising=False)
    with pytest.raises(pytest.fail.Exception, match="no_such_pmr_ros_executable not installed"):
        console_script("no_such_pmr_ros_executable")


# -- declared dependencies -------------------------------------------------------

ROSDEP_KEYS: dict[str, str | None] = {
    # import name -> rosdep key in package.xml; None: no rosdep key exists (package.xml says so in a comment)
    "rclpy": "rclpy",
    "rcl_interfaces": "rcl_interfaces",
    "builtin_interfaces": "builtin_interfaces",
    "std_msgs": "std_msgs",
    "sensor_msgs": "sensor_msgs",
    "diagnostic_msgs": "diagnostic_msgs",
    "rosgraph_msgs": "rosgraph_msgs",
    "ament_index_python": "ament_index_python",
    "numpy": "python3-numpy",
    "scipy": "python3-scipy",
    "yaml": "python3-yaml",
    "rosbags": "python3-rosbags-pip",
    "matplotlib": "python3-matplotlib",
    "pandas": "python3-pandas",
    "jinja2": "python3-jinja2",
    "osqp": None,
    "mcap": None,
    "pyarrow": None,
    "threadpoolctl": None,
    "distributed": None,
    # tests only
    "pytest": "python3-pytest",
    "control": "python-control-pip",
    "mcap_ros2": "mcap-ros2-support",
    "PIL": "python3-pil",
    "lifecycle_msgs": "lifecycle_msgs",  # rclpy.lifecycle's messages: the lifecycle node's test drives it
}


def third_party_imports(folder: Path) -> set[str]:
    """Top-level modules imported anywhere under ``folder`` that are neither the standard library nor the project's."""
    names: set[str] = set()
    for path in folder.rglob("*.py"):
        for node in ast.walk(ast.parse(path.read_text(), filename=str(path))):
            if isinstance(node, ast.Import):
                names.update(alias.name.split(".")[0] for alias in node.names)
            elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
                names.add(node.module.split(".")[0])
    local = {"pmr_ros"} | {p.stem for p in (ROOT / "test").glob("*.py")}  # the tests' own helpers (ros_fixtures, ...)
    return {n for n in names if n not in sys.stdlib_module_names and n not in local}


def message_packages() -> set[str]:
    """ROS 2 packages of the message types the topic contract names (imported by name at run time)."""
    text = (ROOT / "msg_defs" / "topics.yaml").read_text()
    return set(re.findall(r"type:\s*([a-z_0-9]+)/msg/", text))


def test_package_xml_declares_what_the_code_imports():
    root = ElementTree.parse(ROOT / "package.xml").getroot()
    run = {e.text.strip() for tag in ("depend", "exec_depend") for e in root.iter(tag)}
    test = {e.text.strip() for tag in ("depend", "test_depend") for e in root.iter(tag)}
    used = third_party_imports(ROOT / "pmr_ros") | message_packages()
    tested = third_party_imports(ROOT / "test")
    unknown = (used | tested) - ROSDEP_KEYS.keys()
    assert not unknown, (
        f"imports without a decided rosdep key (add them to ROSDEP_KEYS and package.xml): {sorted(unknown)}"
    )
    missing_run = {ROSDEP_KEYS[n] for n in used if ROSDEP_KEYS[n]} - run
    assert not missing_run, f"package.xml lacks <exec_depend> of {sorted(missing_run)}"
    missing_test = {ROSDEP_KEYS[n] for n in tested - used if ROSDEP_KEYS[n]} - test - run
    assert not missing_test, f"package.xml lacks <test_depend> of {sorted(missing_test)}"
    comment = (ROOT / "package.xml").read_text()
    for name in (n for n in used | tested if ROSDEP_KEYS[n] is None):
        assert re.search(rf"^\s+{name}\s", comment, re.MULTILINE), (
            f"package.xml does not say why {name} has no rosdep key"
        )
