"""A full disk while recording: one line, and a bag readable up to the last whole sample (issue 21, item 10)."""

from __future__ import annotations

import errno
import os
import sqlite3

import pytest
from test_bag_faults import _messages, _run_params, _signal, _time

from pmr_ros.bag.reader import open_bag
from pmr_ros.bag.storage import RunConfig, typestore
from pmr_ros.bag.writer import BagWriter
from pmr_ros.cli import main
from pmr_ros.config import load_config
from pmr_ros.contract.layout import read_signal
from pmr_ros.contract.topics import topic

SIGNAL_KEYS = ("setpoint", "manipulated_input", "measured_output")


class FullFile:
    """A file with ``room`` bytes left on its disk: it writes what fits, then raises ENOSPC as the kernel does."""

    def __init__(self, real, room: int) -> None:
        self.real, self.room = real, room

    def write(self, data) -> int:
        if len(data) > self.room:
            self.real.write(bytes(data[: self.room]))
            self.room = 0
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
        self.room -= len(data)
        return self.real.write(data)

    def __getattr__(self, name: str):
        return getattr(self.real, name)


class FullDatabase:
    """An sqlite3 connection whose next commit finds the disk full."""

    def __init__(self, real) -> None:
        self.real = real

    def commit(self) -> None:
        raise sqlite3.OperationalError("database or disk is full")

    def __getattr__(self, name: str):
        return getattr(self.real, name)


def _record_until_full(path, storage: str, *, full_after: int, samples: int = 2048) -> BagWriter:
    """Write ``samples`` samples, flushing every 256; the disk fills after the flush of sample ``full_after``."""
    config = load_config()
    names = {"measured_output": config.model.output_names}
    names |= {"setpoint": config.model.output_names, "manipulated_input": config.model.input_names}
    writer = BagWriter(path, storage=storage, flush_period_s=3600)
    writer.write_run_config(RunConfig(_run_params(samples), source="test"), 1)
    for n, (key, k, values) in enumerate(_messages(samples)):
        if key == "measured_output":
            clock = typestore().types["rosgraph_msgs/msg/Clock"](clock=_time(float(k)))
            writer.write_message(topic("clock").resolved(), 10 + 10 * n, clock)
        writer.write_message(topic(key).resolved(), 11 + 10 * n, _signal(k, values, names[key]))
        if key == "manipulated_input" and (k + 1) % 256 == 0:  # u closes a sample (y, r, u)
            writer.flush()
            if k + 1 == full_after:
                storage_ = writer._writer.storage
                if storage == "mcap":
                    storage_.bio = FullFile(storage_.bio, room=3000)
                else:
                    storage_.conn = FullDatabase(storage_.conn)
    return writer


@pytest.mark.parametrize("storage", ["mcap", "sqlite3"])
def test_a_full_disk_stops_the_writer_with_one_line_and_the_bag_reads_back(tmp_path, storage):
    path = tmp_path / "bag"
    writer = _record_until_full(path, storage, full_after=1024)  # raises nothing into the caller
    assert writer.failure is not None and "\n" not in writer.failure
    reason = "No space left on device" if storage == "mcap" else "database or disk is full"
    assert writer.failure.startswith(f"{path}: cannot write the bag ({reason}); recording stopped")
    assert writer.failure.endswith("1024 whole samples")
    writer.close()  # nothing more is written, and nothing raises
    bag = open_bag(path)
    assert not bag.complete
    for key in SIGNAL_KEYS:
        name = topic(key).resolved()
        assert bag.counts[name] == 1024, (key, bag.counts)
        stamps = [read_signal(typestore().deserialize_cdr(m.data, topic(key).type))[0] for m in bag.messages({name})]
        assert [round(s) for s in stamps] == list(range(1024)), key  # every sample up to the last whole one


@pytest.mark.ros
def test_run_bag_on_a_full_disk_ends_with_one_line_and_a_readable_bag(ros_domain, tmp_path, capsys, monkeypatch):
    """The probe: an OSError [Errno 28] traceback in the recorder's timer callback."""
    original = BagWriter.__init__

    def filling(self, *args, **kwargs):
        original(self, *args, **kwargs)
        self._writer.storage.bio = FullFile(self._writer.storage.bio, room=400_000)

    monkeypatch.setattr(BagWriter, "__init__", filling)
    path = tmp_path / "run_bag"
    assert main(["run", "--samples", "4096", "--bag", str(path)]) == 1
    captured = capsys.readouterr()
    err = captured.err.strip().splitlines()
    assert "Traceback" not in captured.err + captured.out
    line = next(x for x in err if x.startswith("pmr-ros: error: "))
    assert f"{path}: cannot write the bag (No space left on device); recording stopped" in line
    whole = int(line.rsplit(": ", 1)[1].split()[0])
    bag = open_bag(path)
    assert not bag.complete and 0 < whole < 4096
    for key in SIGNAL_KEYS:
        assert bag.counts[topic(key).resolved()] >= whole, (key, bag.counts, whole)
