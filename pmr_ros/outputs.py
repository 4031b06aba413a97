"""Writing output files safely: never onto an input, never half-written, never through a stray symbolic link.

Every file pmr_ros writes (the JSON report, the corrected model, the HTML
report and its figures, the sweep's manifest, summary, figures and report)
goes through :func:`replacing`: the bytes go to a temporary file in the same
folder, are flushed to disk, and only then replace the target with
:func:`os.replace` (atomic on POSIX).  A full disk or a crash leaves the
previous file as it was, never a truncated or empty one.

Before any work, a command checks its output paths with :func:`check_outputs`:
an output that is one of the inputs (the same file, through symbolic links
too), a report folder inside an input (a bag), or an output that is a
symbolic link (unless ``--follow-symlinks``) is refused in one line.
"""

from __future__ import annotations

import argparse
import os
import tempfile
from collections.abc import Iterable, Iterator
from contextlib import contextmanager
from pathlib import Path

__all__ = [
    "OutputError",
    "add_output_arguments",
    "check_outputs",
    "replacing",
    "same_file",
    "write_bytes",
    "write_text",
]

REPORT_FILES = ("index.html", "figures")
"""What an HTML report writes into its folder."""


class OutputError(ValueError):
    """An output path is refused; the one-line message names the option, the path and why."""


def add_output_arguments(parser: argparse.ArgumentParser) -> None:
    """``--follow-symlinks``: write an output that is a symbolic link to where the link points."""
    parser.add_argument(
        "--follow-symlinks",
        action="store_true",
        help="an output path that is a symbolic link is written where the link points (default: refused)",
    )


def same_file(a: str | Path, b: str | Path) -> bool:
    """Whether two paths name the same file or folder (through symbolic links; either may not exist yet)."""
    try:
        return os.path.samefile(a, b)
    except OSError:
        return Path(a).resolve() == Path(b).resolve()


def _inside(path: Path, folder: Path) -> bool:
    """Whether ``path`` (resolved) is ``folder`` or lies under it."""
    resolved, top = path.resolve(), folder.resolve()
    return resolved == top or top in resolved.parents


def _unlinked(path: Path, option: str, *, follow: bool) -> Path:
    """``path``, or where it points when it is a symbolic link and ``follow``; refused otherwise."""
    if not path.is_symlink():
        return path
    if not follow:
        raise OutputError(
            f"{option} {path}: is a symbolic link to {os.readlink(path)}; refusing to write through it "
            "(give --follow-symlinks to write there, or another path)"
        )
    return path.resolve()


def _check_file(path: Path, option: str, inputs: list[Path]) -> None:
    for source in inputs:
        if same_file(path, source) or (source.is_dir() and _inside(path, source)):
            what = "is" if same_file(path, source) else "lies inside"
            raise OutputError(f"{option} {path}: {what} the input {source}; not overwritten: give another path")


def _check_folder(folder: Path, option: str, inputs: list[Path], *, follow: bool) -> None:
    for source in inputs:
        if same_file(folder, source) or (source.is_dir() and _inside(folder, source)):
            raise OutputError(f"{option} {folder}: is or lies inside the input {source}; write the report elsewhere")
        for name in REPORT_FILES:
            if _inside(source, folder / name):
                raise OutputError(
                    f"{option} {folder}: the report's {name} would overwrite the input {source}; write it elsewhere"
                )
    _unlinked(folder / REPORT_FILES[0], f"{option} (its {REPORT_FILES[0]})", follow=follow)


def check_outputs(
    args: argparse.Namespace,
    *,
    inputs: Iterable[str | Path | None],
    files: Iterable[str] = (),
    folders: Iterable[str] = (),
) -> None:
    """Refuse, before any work, output options that would destroy an input or write through a link.

    Parameters
    ----------
    args : argparse.Namespace
        The parsed command line; an output given as a symbolic link is replaced
        by where it points when ``args.follow_symlinks`` is set.
    inputs : iterable of path or None
        What the command reads (data file or bag, configuration); None is skipped.
    files, folders : iterable of str
        Names of the ``args`` attributes that are output files (``json``,
        ``write_model``) and output folders (``report``); the option is
        ``--`` + the name with dashes.

    Raises
    ------
    OutputError
        One line naming the option, the path and the input it would overwrite.
    """
    follow = bool(getattr(args, "follow_symlinks", False))
    sources = [Path(p) for p in inputs if p is not None]
    seen: dict[Path, str] = {}
    for attribute, is_folder in [*((a, False) for a in files), *((a, True) for a in folders)]:
        value = getattr(args, attribute, None)
        if not value:
            continue
        option = "--" + attribute.replace("_", "-")
        path = _unlinked(Path(value), option, follow=follow)
        if is_folder:
            _check_folder(path, option, sources, follow=follow)
        else:
            _check_file(path, option, sources)
        clash = next((other for p, other in seen.items() if same_file(p, path)), None)
        if clash is not None:
            raise OutputError(f"{option} {value}: is also the {clash} output; give each output its own path")
        seen[path] = option
        if path != Path(value):
            setattr(args, attribute, str(path))


@contextmanager
def replacing(path: str | Path) -> Iterator[Path]:
    """A temporary path beside ``path``; on a clean exit it replaces ``path`` atomically, else it is removed.

    The temporary file takes the permissions the target has (or a new file
    would get), and is flushed to disk before the rename, so that after a
    crash or a full disk ``path`` holds either the old or the new contents.

    Raises
    ------
    OSError
        The folder cannot be written, or the disk is full (``path`` unchanged).

    Examples
    --------
    >>> import tempfile
    >>> target = Path(tempfile.mkdtemp()) / "out.txt"
    >>> with replacing(target) as tmp:
    ...     _ = tmp.write_text("done")
    >>> target.read_text()
    'done'
    """
    target = Path(path)
    handle, name = tempfile.mkstemp(prefix=f".{target.name}.", suffix=".tmp", dir=target.parent)
    os.close(handle)
    tmp = Path(name)
    try:
        yield tmp
        _settle(tmp, target)
        os.replace(tmp, target)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise


def _settle(tmp: Path, target: Path) -> None:
    """Give ``tmp`` the target's permissions (a new file's under the umask) and flush it to disk."""
    try:
        mode = target.stat().st_mode & 0o7777
    except OSError:
        umask = os.umask(0)
        os.umask(umask)
        mode = 0o666 & ~umask
    os.chmod(tmp, mode)
    with tmp.open("rb+") as fh:
        os.fsync(fh.fileno())


def write_bytes(path: str | Path, data: bytes) -> None:
    """Write ``data`` to ``path`` atomically (see :func:`replacing`)."""
    with replacing(path) as tmp:
        tmp.write_bytes(data)


def write_text(path: str | Path, text: str, *, encoding: str = "utf-8") -> None:
    """Write ``text`` to ``path`` atomically (see :func:`replacing`)."""
    write_bytes(path, text.encode(encoding))
