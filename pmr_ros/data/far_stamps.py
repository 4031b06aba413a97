"""Time stamps far outside the rest of an export (a year typo): bad rows, not a reason to grid decades.

A historian export of two weeks at one minute with one stamp typed 2260
instead of 2024 would put that row 236 years away: the sample grid from the
first row to the last would hold 124 million samples, gigabytes of nothing.
Such a row is dropped and counted.  A row is *far* when it lies farther than
:data:`FAR_FACTOR` times the whole file's length (its rows at the sample time)
from each of its neighbours -- the first and last row from their one
neighbour.  A shutdown gap in the middle of the data is far from one
neighbour only and is kept (its grid points become a gap).
"""

from __future__ import annotations

import numpy as np

__all__ = ["FAR_FACTOR", "far_stamps", "grid_bytes"]

FAR_FACTOR = 10.0
"""A row this many file lengths (rows x sample time) away from its neighbours is far."""

GRID_COPIES = 4
"""Arrays of the grid's size alive at once while placing and cleaning (values, signals, masks, stretches)."""


def far_stamps(position: np.ndarray) -> np.ndarray:
    """Rows whose stamp lies far from both neighbours (see the module docstring).

    Parameters
    ----------
    position : ndarray, shape (rows,)
        Stamps in samples (seconds over the sample time), in file order.

    Returns
    -------
    ndarray of bool, shape (rows,)

    Examples
    --------
    >>> p = np.arange(100.0)
    >>> p[40] += 236 * 525600  # 2260 for 2024 at one sample a minute
    >>> p[-1] += 100 * 525600
    >>> np.flatnonzero(far_stamps(p)).tolist()
    [40, 99]
    """
    p = np.asarray(position, dtype=float)
    n = p.size
    out = np.zeros(n, dtype=bool)
    if n < 3:
        return out
    far = FAR_FACTOR * n
    jump = np.abs(np.diff(p)) > far  # between row j and j + 1
    out[0], out[-1] = jump[0], jump[-1]
    out[1:-1] = jump[:-1] & jump[1:]
    return out


def grid_bytes(samples: int, columns: int) -> int:
    """Memory the sample grid of ``samples`` points and ``columns`` tags needs while cleaning [bytes]."""
    return 8 * GRID_COPIES * int(samples) * (int(columns) + 2)
