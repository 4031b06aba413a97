"""Read and write the DMCplus text model file (``.mdl``): step-response curves of every CV-MV pair.

The layout, as the public examples and parser of github.com/jamestjsp/dmcplus
show it (documented in docs/models.md), line by line:

1. a comment;
2. the number of file names that follow, then one per line;
3. the number of independents (MVs, feedforwards);
4. the number of dependents (CVs);
5. the number of coefficients N per curve;
6. an integer whose meaning is not publicly documented (carried as it is);
7. the time to steady state [min]: the sample time is this over N;
8. ``9896.000000``, the flag of the new-style layout (the only one read);
9. per independent: ``-999.000000``, its tag and engineering unit;
10. per dependent: ``0.000000``, its tag, unit, ramp flag (0/1) and a count;
11. per dependent, a block: its tag, unit, ramp flag and a number, ten more
    numbers, then per independent its tag, unit and steady-state gain (a
    ramp's rate) and the N coefficients, five per line.
"""

from __future__ import annotations

import re
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .curve_set import CurveSet, ModelFileError

__all__ = ["MdlExtras", "mdl_text", "read_mdl", "write_mdl"]

NEW_STYLE = 9896.0
"""Line 8 of a new-style file."""

BLOCK_NUMBERS = 10
"""Numbers after a dependent's block header, before its curves."""


@dataclass(frozen=True, eq=False)
class MdlExtras:
    """What a ``.mdl`` holds beyond the model, carried to write it again as it was.

    Attributes
    ----------
    file_names : tuple of str
        The file names of lines 2ff.
    header_count : int
        Line 6 (meaning not publicly documented).
    independent_values, dependent_values : ndarray
        The leading number of each tag line (-999, 0 in the examples).
    dependent_counts : ndarray of int
        The last number of each dependent's tag line.
    block_values : ndarray, shape (n_dependents, 11)
        The number of each dependent block header and the ten after it.
    """

    file_names: tuple[str, ...]
    header_count: int
    independent_values: np.ndarray
    dependent_values: np.ndarray
    dependent_counts: np.ndarray
    block_values: np.ndarray


class _Lines:
    """The file's lines with their numbers; a clear error at a premature end."""

    def __init__(self, path: Path, text: str, counts: str = "") -> None:
        self.path, self.counts = path, counts
        self._lines: Iterator[tuple[int, str]] = enumerate(text.splitlines(), start=1)
        self.number = 0

    def next(self, what: str) -> str:
        """The next line; :class:`ModelFileError` if the file ends before ``what``."""
        try:
            self.number, line = next(self._lines)
        except StopIteration:
            raise self.error(f"ends after line {self.number}, before {what}{self.counts}") from None
        return line

    def error(self, reason: str) -> ModelFileError:
        """``FILE line L: reason``."""
        return ModelFileError(f"{self.path} line {self.number}: {reason}")

    def rest(self) -> list[str]:
        """The remaining non-blank lines."""
        return [line for _, line in self._lines if line.strip()]


def _number(lines: _Lines, what: str, *, whole: bool = False) -> float:
    text = lines.next(what).strip()
    try:
        value = float(text)
    except ValueError:
        raise lines.error(f"{what}: {text!r} is not a number") from None
    if whole and value != int(value):
        raise lines.error(f"{what}: {text!r} is not a whole number")
    return value


def _fields(lines: _Lines, what: str, *, lead: int, trail: int) -> tuple[list[str], str, str, list[str]]:
    """``lead`` numbers, a tag, a unit (may hold blanks or be empty), ``trail`` numbers of the next line."""
    line = lines.next(what)
    tokens = line.split()
    if len(tokens) > lead and _is_number(tokens[lead]):
        raise lines.error(f"{what}: expected a tag, found the number {tokens[lead]!r}{lines.counts}")
    pattern = r"^\s*" + r"(\S+)\s+" * lead + r"(\S+)(.*?)" + r"\s+(\S+)" * trail + r"\s*$"
    match = re.match(pattern, line)
    if match is None:
        raise lines.error(
            f"{what}: expected {lead} number(s), a tag, a unit and {trail} number(s), got {line!r}{lines.counts}"
        )
    groups = list(match.groups())
    return groups[:lead], groups[lead], groups[lead + 1].strip(), groups[lead + 2 :]


def _is_number(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


def _floats(lines: _Lines, tokens: list[str], what: str) -> list[float]:
    try:
        return [float(t) for t in tokens]
    except ValueError:
        raise lines.error(f"{what}: {' '.join(tokens)!r} is not all numbers{lines.counts}") from None


def _curve(lines: _Lines, n: int, what: str) -> np.ndarray:
    values: list[float] = []
    while len(values) < n:
        tokens = lines.next(f"coefficient {len(values) + 1} of {n} of {what}").split()
        got = len(values)
        try:
            values.extend(float(t) for t in tokens)
        except ValueError:
            raise lines.error(
                f"{what} has {got} coefficients, not {n}: {tokens[0]!r} comes next{lines.counts}"
            ) from None
    if len(values) > n:
        raise lines.error(f"{what} has more than {n} coefficients ({len(values)}){lines.counts}")
    return np.array(values)


def _header(lines: _Lines) -> tuple[str, tuple[str, ...], list[int], float]:
    """Comment, file names, (independents, dependents, N, line 6), time to steady state."""
    comment = lines.next("the comment line")
    files = tuple(lines.next("a file name").strip() for _ in range(int(_number(lines, "the file count", whole=True))))
    counts = [
        int(_number(lines, what, whole=True)) for what in ("independents", "dependents", "coefficients", "line 6")
    ]
    if min(counts[:3]) < 1:
        raise lines.error(f"independents, dependents and coefficients must be >= 1, got {counts[:3]}")
    steady = _number(lines, "the time to steady state")
    if not steady > 0:
        raise lines.error(f"the time to steady state {steady:g} must be > 0")
    style = _number(lines, "the layout flag")
    if style != NEW_STYLE:
        raise lines.error(f"layout flag {style:g}: only the new-style layout ({NEW_STYLE:g}) is read")
    return comment, files, counts, steady


def _block(lines: _Lines, dep: str, independents: list[str], n: int) -> tuple[float, list, np.ndarray, list[float]]:
    """One dependent's block: ramp flag, its 11 numbers, curves (n_in, N), gains."""
    _, tag, _, trail = _fields(lines, f"the block of dependent {dep}", lead=0, trail=2)
    if tag != dep:
        raise lines.error(f"the block of dependent {dep!r} starts with {tag!r}{lines.counts}")
    ramp, value = _floats(lines, trail, f"the block header of {dep}")
    numbers = [value] + [_number(lines, f"number {j + 1} of the block of {dep}") for j in range(BLOCK_NUMBERS)]
    curves, gains = [], []
    for ind in independents:
        _, tag, _, trail = _fields(lines, f"the curve {dep}/{ind}", lead=0, trail=1)
        if tag != ind:
            raise lines.error(f"expected the curve of independent {ind!r} in {dep}'s block, got {tag!r}{lines.counts}")
        gains.append(_floats(lines, trail, f"the gain of {dep}/{ind}")[0])
        curves.append(_curve(lines, n, f"curve {dep}/{ind}"))
    return ramp, numbers, np.array(curves), gains


def read_mdl(path: str | Path, *, text: str | None = None) -> CurveSet:
    """The curves of a DMCplus ``.mdl`` file (or of its ``text``, ``path`` then only named in messages).

    Raises
    ------
    ModelFileError
        One line naming the file, the line and what is wrong (counts that do
        not match the header, a tag out of order, a non-number).
    """
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8", errors="strict") if text is None else text
    except (OSError, UnicodeDecodeError) as exc:
        raise ModelFileError(f"{path}: cannot read: {getattr(exc, 'strerror', None) or exc}") from None
    lines = _Lines(path, text)
    comment, files, (n_in, n_out, n, line6), steady = _header(lines)
    lines.counts = f" (the header says {n_in} independents, {n_out} dependents, {n} coefficients)"
    ind = [_fields(lines, f"independent {j + 1} of {n_in}", lead=1, trail=0) for j in range(n_in)]
    dep = [_fields(lines, f"dependent {j + 1} of {n_out}", lead=1, trail=2) for j in range(n_out)]
    inputs, outputs = [f[1] for f in ind], [f[1] for f in dep]
    blocks = [_block(lines, name, inputs, n) for name in outputs]
    extra = lines.rest()
    if extra:
        raise lines.error(f"{len(extra)} more line(s) after the last curve{lines.counts}")
    ramp = np.array([b[0] != 0 for b in blocks])
    extras = MdlExtras(
        files,
        line6,
        np.array([_floats(lines, f[0], "independent") for f in ind]).ravel(),
        np.array([_floats(lines, f[0], "dependent") for f in dep]).ravel(),
        np.array([int(float(f[3][1])) for f in dep]),
        np.array([b[1] for b in blocks]),
    )
    return CurveSet(
        sample_time=steady / n,
        output_names=tuple(outputs),
        input_names=tuple(inputs),
        curves=np.array([b[2] for b in blocks]),
        ramp=np.repeat(ramp[:, None], n_in, axis=1),
        gains=np.array([b[3] for b in blocks]),
        output_units=tuple(f[2] for f in dep),
        input_units=tuple(f[2] for f in ind),
        comment=comment,
        extras=extras,
    )


def _gain_text(value: float) -> str:
    """16 significant digits as DMCplus writes them, 17 when needed to read back the same number."""
    text = f"{value:.15e}"
    return text if float(text) == value else f"{value:.16e}"


def _default_extras(curves: CurveSet) -> MdlExtras:
    n_out, n_in = curves.curves.shape[:2]
    nonzero = np.count_nonzero(np.any(curves.curves != 0, axis=2), axis=1)
    return MdlExtras((), 0, np.full(n_in, -999.0), np.zeros(n_out), nonzero, np.zeros((n_out, 1 + BLOCK_NUMBERS)))


def _extras(curves: CurveSet) -> MdlExtras:
    given = curves.extras
    n_out, n_in = curves.curves.shape[:2]
    if isinstance(given, MdlExtras) and given.independent_values.size == n_in and given.block_values.shape[0] == n_out:
        return given
    return _default_extras(curves)


def mdl_text(curves: CurveSet) -> str:
    """The ``.mdl`` text of ``curves`` (coefficients with 7 significant digits, as DMCplus writes them).

    One ramp flag per dependent: a dependent is a ramp if any of its curves is.
    """
    extras = _extras(curves)
    n_out, n_in, n = curves.curves.shape
    out_units, in_units = curves.units(curves.output_names, "outputs"), curves.units(curves.input_names, "inputs")
    ramp = np.any(curves.ramp, axis=1)
    lines = [curves.comment, f"{len(extras.file_names):12d}", *extras.file_names]
    lines += [f"{n_in:12d}", f"{n_out:12d}", f"{n:12d}", f"{extras.header_count:12d}"]
    lines += [f"{curves.time_to_steady_state:16.6f}", f"{NEW_STYLE:16.6f}"]
    for value, tag, unit in zip(extras.independent_values, curves.input_names, in_units, strict=True):
        lines.append(f"{value:16.6f}{'':20s}{tag:<12s} {unit:<12s}")
    for i, tag in enumerate(curves.output_names):
        flag, count = int(ramp[i]), int(extras.dependent_counts[i])
        lines.append(f"{extras.dependent_values[i]:16.6f}{'':20s}{tag:<12s} {out_units[i]:<12s}{flag:6d}{count:6d}")
    for i, tag in enumerate(curves.output_names):
        block = extras.block_values[i]
        lines.append(f"{tag:<12s} {out_units[i]:<12s}{int(ramp[i]):5d}{block[0]:14.6f}")
        lines += [f"{v:16.6f}" for v in block[1:]]
        for k, ind in enumerate(curves.input_names):
            lines.append(f"{ind:<12s} {in_units[k]:<12s}{_gain_text(float(curves.gains[i, k])):>44s}")
            row = curves.curves[i, k].tolist()  # Python floats format several times faster than numpy's
            lines += ["".join(f"{v:15.6e}" for v in row[j : j + 5]) for j in range(0, n, 5)]
    return "\n".join(lines) + "\n"


def write_mdl(curves: CurveSet, path: str | Path) -> None:
    """Write ``curves`` as a ``.mdl`` file (see :func:`mdl_text`).

    Raises
    ------
    ModelFileError
        The file cannot be written, or a tag holds a blank.
    """
    for name in (*curves.output_names, *curves.input_names):
        if not name or any(c.isspace() for c in name):
            raise ModelFileError(f"{path}: tag {name!r} cannot be written to a .mdl file: tags hold no blanks")
    try:
        Path(path).write_text(mdl_text(curves), encoding="utf-8")
    except OSError as exc:
        raise ModelFileError(f"{path}: cannot write: {exc.strerror or exc}") from None
