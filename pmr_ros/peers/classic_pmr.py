"""The project's classic PMR (the seed paper's Table 1) in the peers' per-element shape (a thin adapter).

Named ``classic_pmr`` rather than ``classic`` because ``pmr_ros.core`` has a
``classic`` module already (one file name per module in the package).
"""

from __future__ import annotations

import numpy as np

from ..core.pmr.classic import PmrSettings, diagnose_classic
from ..core.records import Record
from ..core.sim.model import TransferMatrix
from .outcome import PeerOutcome, from_diagnosis

__all__ = ["classic_pmr"]


def classic_pmr(
    r: np.ndarray,
    u: np.ndarray,
    y: np.ndarray,
    *,
    model: TransferMatrix,
    settings: PmrSettings,
) -> dict[str, PeerOutcome]:
    """The classic PMR diagnosis of one gap-free record, per element.

    Parameters
    ----------
    r, u, y : ndarray, shape (N, n_outputs), (N, n_inputs), (N, n_outputs)
        Setpoints, inputs and outputs [their units].
    model : TransferMatrix
        The controller's model ``Ghat``.
    settings : PmrSettings
        The ``pmr`` block (``config.pmr``): Welch estimator and thresholds.

    Returns
    -------
    dict
        Element name to :class:`PeerOutcome` (method ``classic``): detected when
        any of gain, tau index or delay is flagged, score ``|M(0) - 1|``, dK %
        ``100 (M(0) - 1)`` without an interval, dD; empty cells and unreadable
        rows inconclusive with the reason.
    """
    stretch = Record(np.asarray(r, dtype=float), np.asarray(u, dtype=float), np.asarray(y, dtype=float))
    return from_diagnosis(diagnose_classic([stretch], model=model, settings=settings))
