"""Reading pmr_ros bags: complete rosbag2 bags with ``rosbags``, killed recordings by a stream scan.

:func:`open_bag` checks what it is given and always answers with a
:class:`Bag` or a one-line :class:`~pmr_ros.bag.schema.BagError`: a path that
is no bag, an unreadable ``metadata.yaml``, a truncated or corrupted storage
file, an empty bag.  A directory whose recorder was killed (no
``metadata.yaml``, an MCAP file without its summary) is read by scanning the
MCAP records in order up to the last complete chunk, i.e. up to the recorder's
last flush; the bag is then marked ``complete = False``.
"""

from __future__ import annotations

import struct
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path

from ..contract.topics import load_contract
from .schema import RUN_CONFIG_KEY, BagError, RunConfig, typestore


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
    """

    path: Path
    storage: str
    complete: bool
    topics: dict[str, str]
    counts: dict[str, int]
    custom_data: dict[str, str] = field(default_factory=dict)
    _messages: list[BagMessage] | None = field(default=None, repr=False)

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
                f"({type(exc).__name__}: {exc}); the bag is corrupted"
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
        raise BagError(f"{path}: the bag is truncated or corrupted ({type(exc).__name__}: {exc})") from None


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
            return _recover_mcap(path, path)
        raise BagError(f"{path}: not a bag (a rosbag2 bag is a directory with metadata.yaml and a .mcap or .db3 file)")
    files = _storage_files(path)
    if not (path / "metadata.yaml").is_file():
        mcaps = [f for f in files if f.suffix == ".mcap"]
        if len(mcaps) == 1:
            return _recover_mcap(path, mcaps[0])
        if any(f.suffix == ".db3" for f in files):
            raise BagError(
                f"{path}: no metadata.yaml (the recorder did not close this sqlite3 bag); run 'ros2 bag reindex "
                f"{path}' first"
            )
        raise BagError(f"{path}: not a rosbag2 bag (no metadata.yaml and no .mcap file)")
    return _open_complete(path)


def _open_complete(path: Path) -> Bag:
    from rosbags.rosbag2 import Reader

    try:
        reader = Reader(path)
        reader.open()
    except _reader_error_types() as exc:
        raise BagError(f"{path}: cannot read the bag: truncated or corrupted ({type(exc).__name__}: {exc})") from None
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


def _recover_mcap(path: Path, mcap_file: Path) -> Bag:
    """Read an MCAP file record by record up to the first incomplete record (a killed recording)."""
    from mcap.exceptions import McapError
    from mcap.stream_reader import StreamReader

    if mcap_file.stat().st_size == 0:
        raise BagError(f"{path}: the bag is empty ({mcap_file.name} has 0 bytes)")
    scan = _McapScan(path)
    with mcap_file.open("rb") as handle:
        try:
            for record in StreamReader(handle, record_size_limit=1 << 30).records:
                scan.take(record)
        except (McapError, *_reader_error_types()) as exc:
            # The end of a killed recording: everything before this record is whole.
            if not scan.channels:
                raise BagError(f"{path}: not a readable MCAP file ({type(exc).__name__}: {exc})") from None
    if not scan.messages:
        raise BagError(f"{path}: the bag is empty (no complete messages in {mcap_file.name})")
    topics = dict(scan.channels.values())
    counts: dict[str, int] = dict.fromkeys(topics, 0)
    for m in scan.messages:
        counts[m.topic] += 1
    complete = scan.footer and path.is_dir() and (path / "metadata.yaml").is_file()
    return Bag(path, "mcap", complete, topics, counts, {}, scan.messages)
