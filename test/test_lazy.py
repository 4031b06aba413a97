"""The front files' names loaded on first use (pmr_ros._lazy)."""

from __future__ import annotations

import importlib

import pytest

from pmr_ros._lazy import lazy_exports

FRONT_FILES = (
    "pmr_ros",
    "pmr_ros.bag",
    "pmr_ros.contract",
    "pmr_ros.service",
    "pmr_ros.core",
    "pmr_ros.core.sim",
    "pmr_ros.core.mpc",
    "pmr_ros.core.pmr",
    "pmr_ros.core.loop",
    "pmr_ros.models",
    "pmr_ros.peers",
)


def test_a_name_loads_from_its_module_and_an_unknown_one_is_refused():
    getattr_, dir_ = lazy_exports("json", {"JSONDecoder": "decoder"}, ["JSONDecoder"])
    assert getattr_("JSONDecoder") is importlib.import_module("json.decoder").JSONDecoder
    with pytest.raises(AttributeError, match="'json' has no attribute 'nothing'"):
        getattr_("nothing")
    assert "JSONDecoder" in dir_() and "loads" in dir_()


@pytest.mark.parametrize("package", FRONT_FILES)
def test_every_name_a_front_file_lists_resolves(package):
    module = importlib.import_module(package)
    missing = [name for name in module.__all__ if not hasattr(module, name)]
    assert missing == []
    assert set(module.__all__) <= set(dir(module))
