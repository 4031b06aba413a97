"""Reading pmr_ros bags: complete rosbag2 bags with ``rosbags``, killed recordings from what they committed.

:func:`open_bag` checks what it is given and always answers with a
:class:`Bag` or a one-line :class:`~pmr_ros.bag.storage.BagError`: a path that
is no bag, a corrupted storage file, an empty bag.  What a recorder that was
killed left behind is read as far as it is whole, and the bag is marked
``complete = False``:

* an MCAP file without its summary (no ``metadata.yaml``, or one written
  before the file was cut short): its records are scanned in order, chunk
  CRCs checked, up to the first incomplete or damaged one -- the recorder's
  last flush;
* a sqlite3 bag without ``metadata.yaml``: the rows its recorder committed,
  read from a copy of the database (so a pending journal is rolled back there,
  not in the user's files).

:func:`reindex` writes such a bag again as a complete one (summary and
``metadata.yaml``) that stock ``ros2 bag`` reads.
"""

from __future__ import annotations

import shutil
import sqlite3
import struct
import tempfile
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path

from ..contract.topics import load_contract
from .storage import RUN_CONFIG_KEY, BagError, RunConfig, typestore

__all__ = ["Bag", "BagMessage", "open_bag"]


@dataclass(frozen=True)
class BagMessage:
    """One recorded message, still CDR-serialised.

    Attributes
    ----------
    topic : str
    msgtype : str
        ``package/msg/Type``.
    log_time_ns : int
        When the recorder received it [ns since the epoch, wall clock].
    data : bytes
        The CDR bytes as they were on the wire.
    """

    topic: str
    msgtype: str
    log_time_ns: int
    data: bytes


@dataclass
class Bag:
    """An opened bag: its topics, counts, configuration and messages.

    Attributes
    ----------
    path : Path
    storage : str
        ``mcap`` or ``sqlite3``.
    complete : bool
        False for a recording that was not closed (read up to its last flush).
    topics : dict
        Topic name -> message type.
    counts : dict
        Topic name -> messages.
    custom_data : dict
        ``metadata.yaml`` custom_data (empty for an incomplete bag).
    recovery : str
        For an incomplete bag, why it was read by recovery ("" for a complete one).
    """

    path: Path
    storage: str
    complete: bool
    topics: dict[str, str]
    counts: dict[str, int]
    custom_data: dict[str, str] = field(default_factory=dict)
    _messages: list[BagMessage] | None = field(default=None, repr=False)
    recovery: str = ""

    @property
    def message_count(self) -> int:
        """Messages in the bag, all topics."""
        return sum(self.counts.values())

    def messages(self, topics: set[str] | None = None) -> Iterator[BagMessage]:
        """The messages in log-time order (recording order for an incomplete bag)."""
        if self._messages is not None:
            yield from (m for m in self._messages if topics is None or m.topic in topics)
            return
        yield from _read_rosbag2(self.path, topics)

    def decode(self, message: BagMessage):
        """The ``rosbags`` message object of a recorded message."""
        try:
            return typestore().deserialize_cdr(message.data, message.msgtype)
        except Exception as exc:  # any decoding failure of stored bytes means a corrupted record
            raise BagError(
                f"{self.path}: a {message.msgtype} message on {message.topic} cannot be decoded "
                f"({_cause(exc)}); the bag is corrupted"
            ) from None

    def run_config(self) -> RunConfig | None:
        """The recorded configuration: metadata.yaml custom_data, else the run_config topic."""
        config = RunConfig.from_custom_data(self.custom_data)
        if config is not None:
            return config
        # the node set's namespace, whichever it was recorded under (/pmr/run_config, /column_a/pmr/run_config)
        relative = load_contract()[RUN_CONFIG_KEY].name
        name = next((n for n in sorted(self.topics) if n.endswith("/" + relative)), None)
        if name is None:
            return None
        for message in self.messages({name}):
            return RunConfig.from_text(self.decode(message).data)
        return None

    def require(self, topic_names: dict[str, str]) -> None:
        """Check every ``name -> type`` is recorded, with that type and at least one message.

        Raises
        ------
        BagError
            Naming the topic that is missing, empty or of the wrong type.
        """
        for name, msgtype in topic_names.items():
            if name not in self.topics:
                raise BagError(
                    f"{self.path}: topic {name} ({msgtype}) is not in the bag (it has "
                    f"{', '.join(sorted(self.topics)) or 'no topics'})"
                )
            if self.topics[name] != msgtype:
                raise BagError(f"{self.path}: topic {name} has type {self.topics[name]}, expected {msgtype}")
            if not self.counts.get(name):
                raise BagError(f"{self.path}: topic {name} has no messages")


def _reader_error_types():
    """What reading a damaged file raises.

    rosbags' ReaderError, but also whatever a garbage length or offset makes
    the parser hit (OverflowError, AssertionError, struct.error, ...).
    """
    from rosbags.rosbag2.errors import ReaderError

    return (
        ReaderError,
        OSError,
        struct.error,
        ValueError,
        KeyError,
        IndexError,
        EOFError,
        ArithmeticError,
        AssertionError,
        TypeError,
        AttributeError,
        MemoryError,
    )


def _cause(exc: BaseException, limit: int = 240) -> str:
    """An exception as one short line: its type and message, whitespace (libyaml's multi-line marks) folded."""
    text = " ".join(f"{type(exc).__name__}: {exc}".split())
    return text if len(text) <= limit else text[: limit - 3] + "..."


def _read_rosbag2(path: Path, topics: set[str] | None) -> Iterator[BagMessage]:
    from rosbags.rosbag2 import Reader

    try:
        with Reader(path) as reader:
            connections = [c for c in reader.connections if topics is None or c.topic in topics]
            if not connections:
                return  # rosbags reads every topic when given no connections
            for connection, timestamp, data in reader.messages(connections=connections):
                yield BagMessage(connection.topic, connection.msgtype, timestamp, bytes(data))
    except _reader_error_types() as exc:
        raise BagError(f"{path}: the bag is truncated or corrupted ({_cause(exc)})") from None


def _storage_files(path: Path) -> list[Path]:
    return sorted(p for p in path.iterdir() if p.suffix in (".mcap", ".db3"))


def open_bag(path: str | Path) -> Bag:
    """Open a bag directory (or one ``.mcap`` file) and check it can be read.

    Raises
    ------
    BagError
        The path is no bag, the bag is empty, truncated or corrupted.
    """
    path = Path(path)
    if not path.exists():
        raise BagError(f"{path}: no such bag (nothing at this path)")
    if path.is_file():
        if path.suffix == ".mcap":
            return _recover_mcap(path, path, "a lone .mcap file, no metadata.yaml")
        raise BagError(f"{path}: not a bag (a rosbag2 bag is a directory with metadata.yaml and a .mcap or .db3 file)")
    files = _storage_files(path)
    mcaps = [f for f in files if f.suffix == ".mcap"]
    databases = [f for f in files if f.suffix == ".db3"]
    if not (path / "metadata.yaml").is_file():
        if len(mcaps) == 1:
            return _recover_mcap(path, mcaps[0], "no metadata.yaml: its recorder did not close it")
        if databases:
            return _recover_sqlite3(path, databases)
        raise BagError(f"{path}: not a rosbag2 bag (no metadata.yaml, no .mcap or .db3 file)")
    try:
        return _open_complete(path)
    except BagError as exc:
        if len(mcaps) != 1:
            raise BagError(_metadata_problem(path) or str(exc)) from None
        # metadata.yaml was written, but the MCAP file was cut short or damaged after it: read what is whole.
        why = f"not readable whole: {exc.cause}" if isinstance(exc, _Unreadable) else str(exc)
        try:
            return _recover_mcap(path, mcaps[0], why)
        except BagError:
            raise exc from None


def _metadata_problem(path: Path) -> str | None:
    """What is wrong with a bag's metadata.yaml (one line), or None when it parses as a rosbag2 mapping."""
    import yaml

    from ..config.fast_yaml import load as load_yaml_text

    metadata = path / "metadata.yaml"
    try:
        document = load_yaml_text(metadata.read_text(encoding="utf-8"))  # no duplicate key, no alias bomb
    except (OSError, UnicodeDecodeError) as exc:
        return f"{metadata}: cannot be read ({_cause(exc)})"
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        where = f" at line {mark.line + 1}, column {mark.column + 1}" if mark is not None else ""
        problem = " ".join(str(getattr(exc, "problem", None) or exc).split())
        return f"{metadata}: not valid YAML: {problem}{where}"
    if not isinstance(document, dict) or not isinstance(document.get("rosbag2_bagfile_information"), dict):
        return f"{metadata}: not rosbag2 metadata (no 'rosbag2_bagfile_information' mapping)"
    return None


class _Unreadable(BagError):
    """rosbags cannot open a bag that has its metadata.yaml."""

    def __init__(self, path: Path, cause: str) -> None:
        super().__init__(f"{path}: cannot read the bag: truncated or corrupted ({cause})")
        self.cause = cause


def _open_complete(path: Path) -> Bag:
    from rosbags.rosbag2 import Reader

    try:
        reader = Reader(path)
        reader.open()
    except _reader_error_types() as exc:
        raise _Unreadable(path, _cause(exc)) from None
    try:
        topics = {c.topic: c.msgtype for c in reader.connections}
        counts = {c.topic: c.msgcount for c in reader.connections}
        storage = "mcap" if any(p.suffix == ".mcap" for p in _storage_files(path)) else "sqlite3"
        custom = dict(reader.storage.metadata.custom or {})
    finally:
        reader.close()
    bag = Bag(path, storage, True, topics, counts, custom)
    if not bag.message_count:
        raise BagError(f"{path}: the bag is empty (no messages)")
    return bag


class _McapScan:
    """The whole records of an MCAP stream, in order, up to the first broken one."""

    def __init__(self, path: Path) -> None:
        self.path = path
        self.schemas: dict[int, str] = {}
        self.channels: dict[int, tuple[str, str]] = {}
        self.messages: list[BagMessage] = []
        self.footer = False

    def take(self, record: object) -> None:
        from mcap.records import Channel, Footer, Message, Schema

        if isinstance(record, Schema):
            self.schemas[record.id] = record.name
        elif isinstance(record, Channel):
            self.channels[record.id] = (record.topic, self.schemas.get(record.schema_id, ""))
        elif isinstance(record, Message):
            if record.channel_id not in self.channels:
                raise BagError(f"{self.path}: message on unknown channel {record.channel_id}; the file is corrupted")
            topic, msgtype = self.channels[record.channel_id]
            self.messages.append(BagMessage(topic, msgtype, record.log_time, bytes(record.data)))
        elif isinstance(record, Footer):
            self.footer = True


def _recover_mcap(path: Path, mcap_file: Path, why: str = "") -> Bag:
    """Read an MCAP file record by record up to the first incomplete record (a killed recording)."""
    from mcap.exceptions import McapError
    from mcap.stream_reader import StreamReader

    if mcap_file.stat().st_size == 0:
        raise BagError(f"{path}: the bag is empty ({mcap_file.name} has 0 bytes)")
    scan = _McapScan(path)
    with mcap_file.open("rb") as handle:
        try:
            for record in StreamReader(handle, validate_crcs=True, record_size_limit=1 << 30).records:
                scan.take(record)
        except (McapError, *_reader_error_types()) as exc:
            # The end of a killed recording: everything before this record is whole.
            if not scan.channels:
                raise BagError(f"{path}: not a readable MCAP file ({_cause(exc)})") from None
    if not scan.messages:
        raise BagError(f"{path}: the bag is empty (no complete messages in {mcap_file.name})")
    topics = dict(scan.channels.values())
    counts: dict[str, int] = dict.fromkeys(topics, 0)
    for m in scan.messages:
        counts[m.topic] += 1
    complete = scan.footer and path.is_dir() and (path / "metadata.yaml").is_file() and not why
    recovery = "" if complete else (why or "the file was not closed (no summary)")
    return Bag(path, "mcap", complete, topics, counts, {}, scan.messages, recovery)


def _committed_rows(database: Path) -> tuple[dict[int, tuple[str, str]], list[tuple[int, int, bytes]]]:
    """Topics (id -> name, type) and message rows (topic id, timestamp, data) a sqlite3 bag committed."""
    with tempfile.TemporaryDirectory(prefix="pmr_ros_bag_") as folder:
        copy = Path(folder) / database.name
        for companion in (database, *(database.with_name(database.name + s) for s in ("-journal", "-wal"))):
            if companion.is_file():
                shutil.copyfile(companion, copy.with_name(companion.name))
        connection = sqlite3.connect(copy)
        try:
            topics = {int(i): (str(n), str(t)) for i, n, t in connection.execute("SELECT id, name, type FROM topics")}
            rows = connection.execute(
                "SELECT topic_id, timestamp, data FROM messages ORDER BY timestamp, id"
            ).fetchall()
        finally:
            connection.close()
    return topics, [(int(t), int(ts), bytes(data)) for t, ts, data in rows]


def _recover_sqlite3(path: Path, databases: list[Path]) -> Bag:
    """Read the rows a killed sqlite3 recorder committed (no metadata.yaml)."""
    messages: list[BagMessage] = []
    topics: dict[str, str] = {}
    for database in databases:
        try:
            by_id, rows = _committed_rows(database)
        except (sqlite3.Error, OSError) as exc:
            raise BagError(f"{path}: {database.name} is not a readable rosbag2 sqlite3 file ({_cause(exc)})") from None
        topics.update(by_id.values())
        for topic_id, stamp, data in rows:
            if topic_id not in by_id:
                raise BagError(f"{path}: {database.name} holds a message of unknown topic id {topic_id}; corrupted")
            name, msgtype = by_id[topic_id]
            messages.append(BagMessage(name, msgtype, stamp, data))
    if not messages:
        raise BagError(f"{path}: the bag is empty (no committed messages in {', '.join(d.name for d in databases)})")
    messages.sort(key=lambda m: m.log_time_ns)
    counts: dict[str, int] = dict.fromkeys(topics, 0)
    for m in messages:
        counts[m.topic] += 1
    why = "no metadata.yaml: its recorder did not close it; the rows it committed are read"
    return Bag(path, "sqlite3", False, topics, counts, {}, messages, why)
