"""Writing pmr_ros bags with ``rosbags``: rosbag2 directories stock ``ros2 bag`` reads.

Messages are written as they come (already CDR-serialised from the wire, or
serialised here from ``rosbags`` message objects) with their receive time as
the log time, as ``ros2 bag record`` does.  Durability: :meth:`BagWriter.flush`
ends the pending MCAP chunk and pushes it to the disk (sqlite3: commits); it
runs every ``flush_period_s`` from :meth:`BagWriter.write` and from the
recorder's timer, so a recorder killed with SIGKILL loses at most the last
period.  A clean :meth:`BagWriter.close` writes the MCAP summary and
``metadata.yaml`` (with the run's configuration in ``custom_data``).

A write or flush that fails (a full disk: ``OSError`` ENOSPC) does not raise
into the recorder's callbacks: the writer stops, keeps its reason in
:attr:`BagWriter.failure` (one line) and leaves the files as the last flush
left them, which the reader recovers (an MCAP without summary, an sqlite3
database at its last commit).  It writes nothing more, not even a summary,
which would only be cut short again.
"""

from __future__ import annotations

import os
import shutil
import sqlite3
import time
from contextlib import suppress
from pathlib import Path
from typing import TYPE_CHECKING, Final, cast

from ..contract.topics import Topic
from .storage import RUN_CONFIG_KEY, STORAGES, BagError, RunConfig, recorded_topics, rosbags_qos, typestore

__all__ = ["BagWriter", "looks_like_bag", "prepare_output"]

if TYPE_CHECKING:
    from rosbags.rosbag2.storage_mcap import McapWriter
    from rosbags.rosbag2.storage_sqlite3 import Sqlite3Writer

ROSBAG2_VERSION: Final = 9
"""rosbag2 metadata version written (the one ROS 2 Jazzy writes)."""

DISK_ERRORS = (OSError, sqlite3.Error)
"""What a full disk raises: ``OSError`` ENOSPC (MCAP), ``sqlite3.OperationalError`` "database or disk is full"."""

DEFAULT_FLUSH_PERIOD_S = 0.5
"""Longest time between flushes to the disk while recording [s of wall time]."""

BAG_FILE_SUFFIXES = (".mcap", ".db3", ".yaml", ".zstd", ".db3-shm", ".db3-wal", ".db3-journal")


def looks_like_bag(path: Path) -> bool:
    """Whether ``path`` is a directory holding only rosbag2 files (safe to replace with ``--force``)."""
    if not path.is_dir():
        return False
    entries = list(path.iterdir())
    return all(e.is_file() and (e.name == "metadata.yaml" or e.name.endswith(BAG_FILE_SUFFIXES)) for e in entries)


def prepare_output(path: str | Path, force: bool) -> Path:
    """Check a new bag may be written to ``path``; with ``force`` remove an old bag there.

    Raises
    ------
    BagError
        ``path`` exists and ``force`` is off, or it is something else than a
        bag (never deleted, even with ``force``).
    """
    path = Path(path)
    if not path.exists() and not path.is_symlink():
        if not path.parent.is_dir():
            raise BagError(f"{path}: the parent folder {path.parent} does not exist")
        return path
    if not force:
        raise BagError(f"{path} exists already; pass --force to overwrite it")
    if not looks_like_bag(path):
        raise BagError(f"{path} exists and is not a rosbag2 bag; not overwriting it, even with --force")
    shutil.rmtree(path)
    return path


class BagWriter:
    """A rosbag2 bag of the contract's topics, open for writing.

    Parameters
    ----------
    path : str or Path
        The bag directory to create.
    storage : str
        ``mcap`` (default) or ``sqlite3``.
    force : bool
        Replace an existing bag at ``path``.
    flush_period_s : float
        Flush at most this long after the previous flush [s of wall time];
        0 flushes after every message (slow; for tests).
    topics : dict, optional
        Contract key to topic; default: every topic of the contract.

    Raises
    ------
    BagError
        When the bag cannot be created.
    """

    def __init__(
        self,
        path: str | Path,
        *,
        storage: str = "mcap",
        force: bool = False,
        flush_period_s: float = DEFAULT_FLUSH_PERIOD_S,
        topics: dict[str, Topic] | None = None,
    ) -> None:
        from rosbags.rosbag2 import StoragePlugin, Writer
        from rosbags.rosbag2.errors import WriterError

        if storage not in STORAGES:
            raise BagError(f"storage {storage!r}: must be one of {', '.join(STORAGES)}")
        self.path = prepare_output(path, force)
        self.storage = storage
        self.flush_period_s = float(flush_period_s)
        self.topics = dict(topics or recorded_topics())
        self.counts: dict[str, int] = {t.name: 0 for t in self.topics.values()}
        self.flushes = 0
        self.run_config: RunConfig | None = None
        plugin = StoragePlugin.MCAP if storage == "mcap" else StoragePlugin.SQLITE3
        self._writer = Writer(self.path, version=ROSBAG2_VERSION, storage_plugin=plugin)
        try:
            self._writer.open()
        except (WriterError, OSError) as exc:
            raise BagError(f"{self.path}: cannot create the bag: {exc}") from None
        store = typestore()
        self._connections = {}
        for t in self.topics.values():
            self._connections[t.name] = self._writer.add_connection(
                t.name, t.type, typestore=store, offered_qos_profiles=[rosbags_qos(t.qos)]
            )
        self._types = {t.name: t.type for t in self.topics.values()}
        self._last_flush = time.monotonic()
        self._closed = False
        self.failure: str | None = None
        self.flushed_counts = dict(self.counts)

    # -- writing -------------------------------------------------------------
    def write_raw(self, topic_name: str, timestamp_ns: int, data: bytes | memoryview) -> None:
        """Write one CDR-serialised message of ``topic_name`` logged at ``timestamp_ns`` [ns]."""
        connection = self._connections.get(topic_name)
        if connection is None:
            raise BagError(f"{topic_name}: not a recorded topic ({', '.join(self._connections)})")
        if self.failure is not None:
            return  # stopped: the bag keeps what the last flush made durable
        try:
            self._writer.write(connection, int(timestamp_ns), data)
        except DISK_ERRORS as exc:
            self._fail(exc)
            return
        self.counts[topic_name] += 1
        if time.monotonic() - self._last_flush >= self.flush_period_s:
            self.flush()

    def write_message(self, topic_name: str, timestamp_ns: int, message) -> None:
        """Serialise a ``rosbags`` message object of the topic's type and write it."""
        self.write_raw(topic_name, timestamp_ns, typestore().serialize_cdr(message, self._types[topic_name]))

    def keep_run_config(self, config: RunConfig) -> None:
        """Put the run's configuration into ``metadata.yaml`` on close, without a message (one is copied raw)."""
        self.run_config = config
        for key, value in config.custom_data().items():
            self._writer.set_custom_data(key, value)

    def write_run_config(self, config: RunConfig, timestamp_ns: int) -> None:
        """Record the run's configuration: on the ``run_config`` topic now, in metadata.yaml on close.

        It is flushed at once, so even a bag whose recorder is killed keeps it.
        """
        self.keep_run_config(config)
        string = typestore().types["std_msgs/msg/String"]
        self.write_message(self.topics[RUN_CONFIG_KEY].name, timestamp_ns, string(data=config.to_text()))
        self.flush()

    def flush(self) -> None:
        """Make everything written so far durable on disk.

        MCAP: the pending chunk is closed (rosbags otherwise keeps up to 1 MiB
        in memory) and the file flushed and fsync'ed; sqlite3: a commit.
        """
        storage = self._writer.storage
        if storage is None or self.failure is not None:
            return
        try:
            self._flush(storage)
        except DISK_ERRORS as exc:
            self._fail(exc)
            return
        self.flushes += 1
        self._last_flush = time.monotonic()
        self.flushed_counts = dict(self.counts)

    def _flush(self, storage: object) -> None:
        # rosbags types its storage as a protocol; the plugin is the one chosen in __init__ by self.storage
        if self.storage == "mcap":
            mcap = cast("McapWriter", storage)
            if mcap.chunk.bio.tell():
                mcap.close_chunk()
            mcap.bio.flush()
            os.fsync(mcap.bio.fileno())
        else:
            cast("Sqlite3Writer", storage).conn.commit()

    def _fail(self, exc: Exception) -> None:
        """Stop writing after ``exc``: note why (one line) and let go of the files without writing more."""
        why = " ".join(str(getattr(exc, "strerror", None) or exc).split())
        self.failure = (
            f"{self.path}: cannot write the bag ({why}); recording stopped, the bag keeps what was "
            f"flushed before: {self.whole_samples()} whole samples"
        )
        self._abandon()

    def whole_samples(self) -> int:
        """Samples of which r, u and y all reached the disk at the last flush."""
        signals = [
            t.name for key, t in self.topics.items() if key in ("setpoint", "manipulated_input", "measured_output")
        ]
        return min((self.flushed_counts.get(name, 0) for name in signals), default=0)

    def _abandon(self) -> None:
        """Close the storage's files as they are (no chunk, summary or metadata.yaml is written)."""
        storage = self._writer.storage
        self._closed = True
        with suppress(Exception):  # a file the full disk left half-written still closes; nothing to add
            if self.storage == "mcap":
                cast("McapWriter", storage).bio.close()
            else:
                cast("Sqlite3Writer", storage).conn.close()

    # -- end -----------------------------------------------------------------
    @property
    def message_count(self) -> int:
        """Messages written so far, all topics."""
        return sum(self.counts.values())

    def close(self) -> None:
        """Write the index/summary and ``metadata.yaml``; the bag is complete."""
        if self._closed:
            return
        self._closed = True
        try:
            self._writer.close()
        except DISK_ERRORS as exc:  # the summary or metadata.yaml did not fit: the bag is read without them
            why = " ".join(str(getattr(exc, "strerror", None) or exc).split())
            self.failure = self.failure or f"{self.path}: cannot close the bag ({why}); read it as is"

    def __enter__(self) -> BagWriter:
        return self

    def __exit__(self, *exc) -> None:
        self.close()
