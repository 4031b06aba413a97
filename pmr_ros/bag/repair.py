"""Writing a bag that was not closed again as a complete one (``pmr-ros reindex``).

A recorder killed mid-run leaves an MCAP file without its summary, or a
sqlite3 database without ``metadata.yaml``; :func:`pmr_ros.bag.reader.open_bag`
reads what they hold, but stock ``ros2 bag`` tools do not.  :func:`reindex`
copies every message that can be read, with its log time and bytes unchanged,
into a new complete bag (summary, ``metadata.yaml`` with the run's
configuration); the original is left as it is.
"""

from __future__ import annotations

from pathlib import Path

from .reader import Bag
from .storage import BagError, recorded_topics
from .writer import BagWriter

__all__ = ["reindex"]

NO_FLUSH = 3600.0
"""Flush period while copying [s]: the copy is flushed once, when it is closed."""


def reindex(bag: Bag, out: str | Path, *, storage: str | None = None, force: bool = False) -> BagWriter:
    """Copy every readable message of ``bag`` into a new, complete bag at ``out``.

    Parameters
    ----------
    bag : Bag
        An opened bag (usually one whose recorder was killed).
    out : str or Path
        The new bag's directory.
    storage : str, optional
        ``mcap`` or ``sqlite3``; default: the bag's own.
    force : bool
        Replace an existing bag at ``out``.

    Returns
    -------
    BagWriter
        The closed writer (``counts``: messages per topic).

    Raises
    ------
    BagError
        ``out`` cannot be written, or the bag has a topic outside the pmr_ros contract.
    """
    contract = recorded_topics()
    by_name = {t.name: key for key, t in contract.items()}
    foreign = sorted(name for name in bag.topics if name not in by_name)
    if foreign:
        raise BagError(f"{bag.path}: topic {foreign[0]} is not one of the pmr_ros contract; cannot reindex it")
    topics = {by_name[name]: contract[by_name[name]] for name in bag.topics}
    writer = BagWriter(out, storage=storage or bag.storage, force=force, flush_period_s=NO_FLUSH, topics=topics)
    try:
        config = bag.run_config()
        if config is not None:
            writer.keep_run_config(config)
        for message in bag.messages():
            writer.write_raw(message.topic, message.log_time_ns, message.data)
    finally:
        writer.close()
    return writer
