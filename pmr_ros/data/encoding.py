"""The text encoding of a CSV export from its byte-order mark: UTF-8 (with or without one) or UTF-16.

Windows tools (Excel's "Unicode text", some historian clients) save UTF-16
with a byte-order mark; its every other byte is 0, which once made such a file
"binary".  A UTF-32 mark is named and refused; NUL bytes without a mark are
binary data.
"""

from __future__ import annotations

import codecs
from pathlib import Path

from .bad_data import DataError

__all__ = ["csv_encoding"]

_UTF32 = (codecs.BOM_UTF32_LE, codecs.BOM_UTF32_BE)
_UTF16 = (codecs.BOM_UTF16_LE, codecs.BOM_UTF16_BE)


def csv_encoding(head: bytes, path: str | Path) -> str:
    r"""The Python codec that reads a CSV file whose first bytes are ``head``.

    Examples
    --------
    >>> csv_encoding("t,y\n1,2\n".encode("utf-16"), "a.csv")
    'utf-16'
    >>> csv_encoding(b"t,y\n1,2\n", "a.csv")
    'utf-8-sig'

    Raises
    ------
    DataError
        A UTF-32 file (named), or NUL bytes without a byte-order mark (binary data).
    """
    if head.startswith(_UTF32):  # before UTF-16: the UTF-32 LE mark starts with the UTF-16 LE one
        raise DataError(path, "", "is UTF-32 text (its byte-order mark says so); save the export as UTF-8 or UTF-16")
    if head.startswith(_UTF16):
        return "utf-16"
    if b"\0" in head:
        raise DataError(path, "", "not a CSV file: it holds binary data")
    return "utf-8-sig"
