"""The silence watchdog of a consumer of signal topics: which topics stopped, and the one line that says so.

Kept apart from the node (no rclpy here): the node tells when a sample arrived and whether it is busy, and
asks, on a wall-clock timer, whether a silence is to be reported now.
"""

from __future__ import annotations

import time
from collections.abc import Mapping, Sequence


class SilenceWatch:
    """Wall-clock arrivals per signal; a silence longer than ``timeout_s`` is reported once per ``timeout_s``.

    Parameters
    ----------
    signals : sequence of str
        The watched signals (e.g. ``r``, ``u``, ``y``).
    labels : mapping
        Signal -> how a line names it (``u on /pmr/manipulated_input``).
    """

    def __init__(self, signals: Sequence[str], labels: Mapping[str, str]) -> None:
        self.signals, self.labels = tuple(signals), dict(labels)
        self.last_arrival: dict[str, float | None] = dict.fromkeys(self.signals)
        self.created = time.monotonic()
        self._busy_at = 0.0  # when the consumer was last seen busy [s of monotonic time]
        self._reported: float | None = None

    def arrived(self, signal: str) -> None:
        """A sample of ``signal`` arrived now."""
        self.last_arrival[signal] = time.monotonic()

    def busy(self) -> None:
        """The consumer is diagnosing: silence counts from when it is done.

        Lockstep producers wait for it, or the last window is diagnosed; on a machine under load the
        final diagnosis alone outlasted the timeout.
        """
        self._busy_at = time.monotonic()

    def report(self, timeout_s: float) -> tuple[str, bool] | None:
        """The silence to report now: (reason, whether any signal ever arrived), or None.

        Parameters
        ----------
        timeout_s : float
            Silence longer than this is reported, again at most once per this time [s].
        """
        now = time.monotonic()
        silent = [s for s in self.signals if now - max(self.last_arrival[s] or self.created, self._busy_at) > timeout_s]
        if not silent:
            self._reported = None
            return None
        if self._reported is not None and now - self._reported < timeout_s:
            return None
        self._reported = now
        never = [s for s in silent if self.last_arrival[s] is None]
        heard = len(never) < len(self.signals)
        if not heard:
            return f"no data received in {now - self.created:.1f} s", False
        return "; ".join(
            f"no {self.labels[s]} for {now - (self.last_arrival[s] or self.created):.1f} s" for s in silent
        ), True
