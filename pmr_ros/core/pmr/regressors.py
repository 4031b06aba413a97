"""The regressors of one output row's regression: each modeled element's output, an empty cell's reference.

See :mod:`.spectra` ("The regression of one output row") for why an empty cell's regressor is ``u_k(t - 1)``
(times ``Ts`` integrated in an integrating row).
"""

from __future__ import annotations

import numpy as np

from ..sim.model import TransferMatrix

__all__ = ["row_regressors"]


def row_regressors(model: TransferMatrix, u: np.ndarray, i: int) -> np.ndarray:
    """The regressors ``x_ik`` of row ``i`` (undifferenced), shape (N, n_in).

    ``Ghat_ik u_k`` for a modeled element, started as
    :meth:`TransferMatrix.element_outputs` starts it; for an empty cell the
    reference ``u_k(t-1)`` (times ``Ts`` integrated, in an integrating row).
    """
    u = np.asarray(u, dtype=float)
    x = np.empty_like(u)
    x[0] = u[0]
    x[1:] = u[:-1]
    if model.integrating_outputs[i]:
        x = np.cumsum(x, axis=0) * model.sample_time
    present = np.flatnonzero(model.present[i])
    if present.size:
        row = _model_row(model, i)
        x[:, present] = row.element_outputs(u[:, present])[:, 0, :]
    return x


def _model_row(model: TransferMatrix, i: int) -> TransferMatrix:
    """Row ``i`` of the model, with only its modeled elements (a 1 x n_present matrix), any element type."""
    row = [model.element(i, int(k)) for k in np.flatnonzero(model.present[i])]
    return TransferMatrix.of_elements([row], sample_time=model.sample_time)
