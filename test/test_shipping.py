"""Large arrays to pool workers through memory-mapped files (:mod:`pmr_ros.service.shipping`)."""

from __future__ import annotations

import pickle

import numpy as np
import pytest

from pmr_ros.service.shipping import SHIPPED_MIN_BYTES, ship, unship


def test_large_arrays_travel_as_read_only_maps_and_the_rest_in_the_pickle(tmp_path):
    rng = np.random.default_rng(5)
    big = rng.standard_normal((SHIPPED_MIN_BYTES // 8 + 10, 1))
    small, labels = np.arange(10.0), np.array(["a", None], dtype=object)
    obj = {"signals": {"y": big, "u": big[:, 0] * 2.0}, "small": small, "labels": labels, "name": "column"}
    blob = ship(obj, tmp_path)
    assert len(blob) < 10_000 < len(pickle.dumps(obj))  # the pickle holds references, not the samples
    assert sorted(p.name for p in tmp_path.iterdir()) == ["array_0000.npy", "array_0001.npy"]
    back = unship(blob)
    for name in ("y", "u"):
        shipped = back["signals"][name]
        np.testing.assert_array_equal(shipped, obj["signals"][name])  # exact: the same bytes
        assert type(shipped) is np.ndarray and isinstance(shipped.base, np.memmap) and not shipped.flags.writeable
        with pytest.raises(ValueError, match="read-only"):
            shipped[0] = 1.0  # a worker cannot change what the others read
    assert type(back["small"]) is np.ndarray and back["small"].flags.writeable
    np.testing.assert_array_equal(back["small"], small)
    assert back["labels"].tolist() == ["a", None] and back["name"] == "column"


def test_the_threshold_is_a_keyword(tmp_path):
    back = unship(ship({"x": np.ones(4)}, tmp_path, min_bytes=1))
    assert isinstance(back["x"].base, np.memmap) and back["x"].tolist() == [1.0] * 4
