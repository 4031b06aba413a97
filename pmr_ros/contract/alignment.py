"""Aligning setpoints r, inputs u and outputs y by sample, from messages that may misbehave.

Messages carry their sample time as a stamp; sample k has the stamp k * Ts, so
the index is ``k = round(stamp / Ts)``.  A sample is *complete* once r(k), u(k)
and y(k) have all arrived, in whatever order.  The diagnostician only ever uses
the newest unbroken stretch of complete samples: the PMR's spectra and the
model's element outputs assume evenly spaced, gap-free records, so a missing
or rejected sample ends the stretch and the window restarts after it.

Rejected, with a reason naming the signal, its topic and the value:
non-finite values, a wrong number of values or wrong channel names, stamps off
the sample grid, and duplicated or out-of-order stamps (each signal's index
must strictly increase; the first message of a sample wins).

No rclpy here: this module is plain Python/numpy and is tested without ROS.
"""

from __future__ import annotations

import copy
from collections import deque
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np

SIGNALS = ("r", "u", "y")
"""Signals the diagnostician aligns: setpoints, inputs, outputs."""

GRID_TOLERANCE = 0.25
"""Largest distance of a stamp from the sample grid [samples] still accepted."""


def sample_index(stamp_s: float, sample_time_s: float) -> tuple[int, float]:
    """The sample index of a stamp and its distance from the grid.

    Parameters
    ----------
    stamp_s : float
        Stamp [s].
    sample_time_s : float
        Ts [s].

    Returns
    -------
    index : int
        ``round(stamp / Ts)``.
    offset : float
        ``stamp / Ts - index`` [samples], in [-0.5, 0.5].
    """
    position = stamp_s / sample_time_s
    index = int(round(position))
    return index, position - index


def check_signal(
    label: str, names: Sequence[str], values: Sequence[float] | np.ndarray, expected_names: Sequence[str]
) -> str | None:
    """Why a signal message is unusable, or None if it is fine.

    ``names`` may be empty (then values are taken in the configured order);
    otherwise they must equal ``expected_names``.
    """
    width = len(expected_names)
    if len(values) != width:
        return (
            f"{label}: {len(values)} values {np.asarray(values, dtype=float).tolist()!r}, expected {width} "
            f"({', '.join(expected_names)}); message dropped"
        )
    if len(names) and tuple(names) != tuple(expected_names):
        return (
            f"{label}: channel names {list(names)!r} differ from the configured {list(expected_names)!r}; message "
            "dropped"
        )
    array = np.asarray(values, dtype=float)
    if not np.all(np.isfinite(array)):
        bad = [f"{n}={v}" for n, v in zip(expected_names, array.tolist(), strict=True) if not np.isfinite(v)]
        return f"{label}: non-finite value {', '.join(bad)}; message dropped"
    return None


@dataclass
class AddResult:
    """What adding one message did.

    Attributes
    ----------
    accepted : bool
    warnings : list of str
        Human-readable reasons (rejections, gaps, restarts of the window).
    completed : list of int
        Sample indices that became complete.
    """

    accepted: bool
    warnings: list[str] = field(default_factory=list)
    completed: list[int] = field(default_factory=list)


class SampleAligner:
    """Assembles complete samples of r, u and y and keeps the newest unbroken stretch.

    Parameters
    ----------
    sample_time_s : float
        Ts [s].
    channel_names : dict
        Signal (``r``, ``u``, ``y``) to its channel names.
    labels : dict
        Signal to how warnings name it, e.g. ``"y on /pmr/measured_output"``.
    capacity : int
        Samples of the stretch kept (the diagnosis window).
    max_lag_samples : int
        A signal this many samples behind the newest one counts as stopped.
    """

    def __init__(
        self,
        sample_time_s: float,
        channel_names: Mapping[str, Sequence[str]],
        labels: Mapping[str, str],
        capacity: int,
        max_lag_samples: int,
    ) -> None:
        self.sample_time_s = float(sample_time_s)
        self.channel_names = {s: tuple(channel_names[s]) for s in SIGNALS}
        self.labels = dict(labels)
        self.capacity = int(capacity)
        self.max_lag_samples = int(max_lag_samples)
        self.newest: dict[str, int | None] = {s: None for s in SIGNALS}
        self.rejected: dict[str, int] = {s: 0 for s in SIGNALS}
        self.gaps = 0
        self._pending: dict[int, dict[str, np.ndarray]] = {}
        self._rows: dict[str, deque] = {s: deque(maxlen=self.capacity) for s in SIGNALS}
        self.stretch_first: int | None = None
        self.stretch_last: int | None = None

    # -- state -------------------------------------------------------------
    @property
    def stretch_length(self) -> int:
        """Complete samples in the current unbroken stretch (not capped at capacity)."""
        if self.stretch_first is None or self.stretch_last is None:  # both None together
            return 0
        return self.stretch_last - self.stretch_first + 1

    def window(self, samples: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, int]:
        """The newest ``samples`` (at most) of the stretch: ``r, u, y, first_index``.

        Raises
        ------
        ValueError
            No sample is complete yet (there is no stretch).
        """
        if self.stretch_last is None:
            raise ValueError("no complete sample yet: the stretch is empty")
        take = min(samples, len(self._rows["r"]))
        out = [np.array(list(self._rows[s])[len(self._rows[s]) - take :]) for s in SIGNALS]
        return out[0], out[1], out[2], self.stretch_last - take + 1

    def snapshot(self) -> SampleAligner:
        """A copy of the aligned samples that later messages do not change.

        For diagnosing on another thread while messages keep coming (the live
        diagnostician): the copy answers ``window``, ``lagging``,
        ``stretch_*`` and ``gaps`` as this aligner does now.  The sample
        arrays, never modified once stored, are shared; the containers are not.
        """
        twin = copy.copy(self)
        twin.newest = dict(self.newest)
        twin.rejected = dict(self.rejected)
        twin._pending = {}
        twin._rows = {s: deque(self._rows[s], maxlen=self.capacity) for s in SIGNALS}
        return twin

    def value(self, signal: str, k: int) -> np.ndarray | None:
        """The values of ``signal`` taken for sample ``k``, if still held (waiting, or in the stretch).

        For telling a repeated message from an inconsistent one (the same
        stamp with other values: two publishers on one topic).
        """
        waiting = self._pending.get(k, {}).get(signal)
        if waiting is not None:
            return waiting
        if self.stretch_last is None or not self.stretch_last - len(self._rows[signal]) < k <= self.stretch_last:
            return None
        return self._rows[signal][k - self.stretch_last - 1]

    def restart(self) -> None:
        """Begin a new stretch after a break the stamps do not show (samples that cannot be trusted).

        The complete samples are forgotten, as after a gap; what comes next starts a new stretch.
        """
        if self.stretch_last is not None:
            self.gaps += 1
        for s in SIGNALS:
            self._rows[s].clear()
        self.stretch_first = self.stretch_last = None

    def resize(self, capacity: int) -> None:
        """Keep up to ``capacity`` samples from now on (newest first kept)."""
        self.capacity = int(capacity)
        for s in SIGNALS:
            self._rows[s] = deque(self._rows[s], maxlen=self.capacity)

    def lagging(self) -> str | None:
        """Why the data are stale (a signal stopped or never came), or None."""
        seen = [k for k in self.newest.values() if k is not None]
        if not seen:
            return None
        head = max(seen)
        for s in SIGNALS:
            k = self.newest[s]
            if k is None and head + 1 > self.max_lag_samples:
                return f"no {self.labels[s]} received while the other signals reached sample {head}"
            if k is not None and head - k > self.max_lag_samples:
                return f"{self.labels[s]} stopped at sample {k} while the other signals reached sample {head}"
        return None

    # -- input -------------------------------------------------------------
    def add(self, signal: str, stamp_s: float, names: Sequence[str], values: Sequence[float] | np.ndarray) -> AddResult:
        """Offer one message of ``signal``; returns what happened, never raises on bad data."""
        label = self.labels[signal]
        problem = check_signal(label, names, values, self.channel_names[signal])
        if problem is None and not np.isfinite(stamp_s):
            problem = f"{label}: stamp {stamp_s!r} s is not finite; message dropped"
        if problem is not None:
            self.rejected[signal] += 1
            return AddResult(False, [problem])
        k, offset = sample_index(stamp_s, self.sample_time_s)
        if abs(offset) > GRID_TOLERANCE:
            self.rejected[signal] += 1
            return AddResult(
                False,
                [
                    f"{label}: stamp {stamp_s:.9g} s is {offset:+.2f} samples off the sample grid (Ts = "
                    f"{self.sample_time_s:g} s); message dropped"
                ],
            )
        last = self.newest[signal]
        if last is not None and k <= last:
            self.rejected[signal] += 1
            kind = "duplicated" if k == last else "out-of-order"
            return AddResult(
                False, [f"{label}: {kind} stamp {stamp_s:.9g} s (sample {k}, newest is {last}); message dropped"]
            )
        result = AddResult(True)
        if last is not None and k > last + 1:
            result.warnings.append(f"{label}: samples {last + 1}..{k - 1} missing (gap of {k - last - 1})")
        self.newest[signal] = k
        if self.stretch_last is not None and k <= self.stretch_last:
            # Another signal already completed a later sample: this one cannot join the stretch.
            result.warnings.append(
                f"{label}: sample {k} arrived after sample {self.stretch_last} was complete; dropped"
            )
            return result
        entry = self._pending.setdefault(k, {})
        entry[signal] = np.asarray(values, dtype=float)
        if len(entry) == len(SIGNALS):
            self._complete(k, result)
        self._trim_pending()
        return result

    def _complete(self, k: int, result: AddResult) -> None:
        entry = self._pending.pop(k)
        if self.stretch_last is not None and k != self.stretch_last + 1:
            self.gaps += 1
            missing = self._missing_between(self.stretch_last + 1, k)
            result.warnings.append(
                f"samples {self.stretch_last + 1}..{k - 1} incomplete ({missing}): the window restarts at sample {k} "
                f"after {self.stretch_length} samples"
            )
            for s in SIGNALS:
                self._rows[s].clear()
            self.stretch_first = None
        for old in [j for j in self._pending if j < k]:
            del self._pending[old]
        if self.stretch_first is None:
            self.stretch_first = k
        self.stretch_last = k
        for s in SIGNALS:
            self._rows[s].append(entry[s])
        result.completed.append(k)

    def _missing_between(self, first: int, last_exclusive: int) -> str:
        missing: set[str] = set()
        for j in range(first, last_exclusive):
            have = self._pending.get(j, {})
            missing.update(s for s in SIGNALS if s not in have)
        return "missing " + ", ".join(s for s in SIGNALS if s in missing) if missing else "rejected"

    def _trim_pending(self) -> None:
        # Samples far behind the newest message can never complete in a live stream; bound the memory.
        if len(self._pending) > 4 * self.max_lag_samples + 16:
            head = max(k for k in self.newest.values() if k is not None)
            for old in [j for j in self._pending if j < head - 2 * self.max_lag_samples]:
                del self._pending[old]
