"""Packaging: the version in one place (package.xml).

Install layouts are faked in tmp dirs, with the checkout itself hidden
(``pmr_ros.resources.SOURCE_ROOT``) so the lookup cannot fall back on it.
"""

from __future__ import annotations

import importlib.metadata
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

import pmr_ros
from pmr_ros import _version, resources

ROOT = Path(__file__).resolve().parents[1]


def manifest_version(path: Path) -> str:
    """``<version>`` of a package.xml by a regular expression (not the parser under test)."""
    match = re.search(r"<version>\s*([^<\s]+)\s*</version>", path.read_text())
    assert match, f"{path} has no <version>"
    return match.group(1)


def write_manifest(folder: Path, version: str, name: str = "pmr_ros") -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / "package.xml"
    path.write_text(f'<?xml version="1.0"?>\n<package format="3">\n  <name>{name}</name>\n  <version>{version}</version>\n</package>\n')
    return path


@pytest.fixture
def nothing_installed(tmp_path, monkeypatch) -> Path:
    """Every place share_dir looks is empty: no checkout, no sourced workspace, an empty interpreter prefix."""
    monkeypatch.setattr(resources, "SOURCE_ROOT", tmp_path / "site-packages")
    monkeypatch.setattr(sys, "prefix", str(tmp_path / "venv"))
    monkeypatch.setattr(sys, "base_prefix", str(tmp_path / "base"))
    monkeypatch.delenv("AMENT_PREFIX_PATH", raising=False)
    return tmp_path


# -- version -------------------------------------------------------------------


def test_version_is_the_one_in_package_xml():
    assert pmr_ros.__version__ == manifest_version(ROOT / "package.xml")


def test_setup_py_takes_the_version_from_package_xml(tmp_path):
    shutil.copy(ROOT / "setup.py", tmp_path)
    write_manifest(tmp_path, "9.8.7")
    proc = subprocess.run([sys.executable, "setup.py", "--version"], cwd=tmp_path, capture_output=True, text=True, timeout=120)
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
