"""A small text progress bar with an ETA, on stderr (the sweep's runs, the bytes of a long data file, windows)."""

from __future__ import annotations

import sys
import time
from collections.abc import Callable
from typing import TextIO


def format_duration(seconds: float) -> str:
    """``75`` -> ``1m15s``; ``3700`` -> ``1h01m``."""
    seconds = max(0, int(round(seconds)))
    if seconds < 60:
        return f"{seconds}s"
    if seconds < 3600:
        return f"{seconds // 60}m{seconds % 60:02d}s"
    return f"{seconds // 3600}h{(seconds % 3600) // 60:02d}m"


class ProgressBar:
    """``label [#####.....] 12/40 runs  30% 0m20s elapsed, ETA 0m46s``.

    Redrawn in place on a terminal; elsewhere (logs, pipes) one line per
    10 % so a log stays short.

    Parameters
    ----------
    total : int
        Units of work (closed-loop runs, bytes).
    label : str
    unit : str
        What is counted, shown after the counts (``runs``); ``MB`` shows a
        count of bytes in megabytes.
    stream : text stream, default ``sys.stderr``
    width : int
        Characters of the bar.
    """

    def __init__(
        self, total: int, label: str = "sweep", stream: TextIO | None = None, width: int = 30, *, unit: str = "runs"
    ) -> None:
        self.total, self.label, self.width, self.unit = max(int(total), 0), label, width, unit
        self.stream = stream if stream is not None else sys.stderr
        self.done = 0
        self.start = time.monotonic()
        self._tty = bool(getattr(self.stream, "isatty", lambda: False)())
        self._last_decile = -1

    def line(self) -> str:
        """The bar's current text."""
        frac = self.done / self.total if self.total else 1.0
        filled = int(round(frac * self.width))
        elapsed = time.monotonic() - self.start
        eta = elapsed / self.done * (self.total - self.done) if self.done else float("nan")
        eta_text = format_duration(eta) if self.done else "?"
        return (
            f"{self.label} [{'#' * filled}{'.' * (self.width - filled)}] {self._count()} "
            f"{100 * frac:3.0f}% {format_duration(elapsed)} elapsed, ETA {eta_text}"
        )

    def _count(self) -> str:
        if self.unit == "MB":
            return f"{self.done / 1e6:.1f}/{self.total / 1e6:.1f} MB"
        return f"{self.done}/{self.total} {self.unit}"

    def update(self, advance: int) -> None:
        """Count ``advance`` more units done and redraw."""
        self.done = min(self.total, self.done + int(advance))
        if self._tty:
            self.stream.write("\r" + self.line())
        else:
            decile = int(10 * self.done / self.total) if self.total else 10
            if decile == self._last_decile:
                return
            self._last_decile = decile
            self.stream.write(self.line() + "\n")
        self.stream.flush()

    def close(self) -> None:
        """End the bar's line."""
        if self._tty:
            self.stream.write("\n")
            self.stream.flush()


def progress_callback(
    label: str, *, unit: str | None = None
) -> tuple[Callable[[int, int], None] | None, Callable[[], None]]:
    """A progress bar with an ETA on a terminal (stderr), None (quiet) elsewhere; and a function that ends it.

    ``update(done, total)`` draws it; ``unit`` is what is counted (default: MB of a CSV, else rows).
    """
    if not sys.stderr.isatty():
        return None, lambda: None
    bar: list[ProgressBar] = []
    counted = unit or ("MB" if label.endswith("csv") else "rows")

    def update(done: int, total: int) -> None:
        if not bar:
            bar.append(ProgressBar(total, label, stream=sys.stderr, unit=counted))
        bar[0].update(done - bar[0].done)

    return update, lambda: bar[0].close() if bar else None
