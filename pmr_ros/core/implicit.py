"""The implicit MIMO plant-model ratio estimate (the paper's eq. 13), frequency by frequency.

For output row i the estimate solves, at every frequency, the
setpoint-correlated regression

    S_{r_l y_i}(w) = sum_k S_{r_l yhat_ik}(w) G_PMR_ik(w),   l = 1 .. n_setpoints

with ``yhat_ik = Ghat_ik u_k`` the model's share of output i due to input k.
Noise and disturbances drop out because they are uncorrelated with r.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .foptd import FoptdMatrix
from .record import check_record
from .spectra import RecordSpectra, WelchSettings, record_spectra

__all__ = ["PmrEstimate", "estimate_pmr", "implicit_estimate"]


@dataclass(frozen=True)
class PmrEstimate:
    """The estimated PMR matrix over frequency.

    Attributes
    ----------
    omega : ndarray, shape (F,)
        Frequencies 0 .. pi [rad/sample].
    ratio : ndarray of complex, shape (F, n_outputs, n_inputs)
        ``G_PMR_ik(w)``.
    coherence : ndarray, shape (F, n_outputs)
        Multiple squared coherence of output i with the setpoints: the share
        of its spectrum the setpoints explain.
    condition : ndarray, shape (F, n_outputs)
        Condition number of each row's regression matrix.
    segments : int
        Welch segments averaged.
    """

    omega: np.ndarray
    ratio: np.ndarray
    coherence: np.ndarray
    condition: np.ndarray
    segments: int


def implicit_estimate(spectra: RecordSpectra) -> PmrEstimate:
    """Solve eq. (13) row by row and frequency by frequency.

    Parameters
    ----------
    spectra : RecordSpectra
        The record's cross-spectra.

    Returns
    -------
    PmrEstimate
    """
    F, _, n_out, n_in = spectra.ryhat.shape
    ratio = np.empty((F, n_out, n_in), dtype=complex)
    condition = np.empty((F, n_out))
    coherence = np.empty((F, n_out))
    rr_inv = np.linalg.pinv(spectra.rr)
    for i in range(n_out):
        design = spectra.ryhat[:, :, i, :]  # (F, n_r, n_in)
        target = spectra.ry[:, :, i]  # (F, n_r)
        ratio[:, i, :] = (np.linalg.pinv(design) @ target[:, :, None])[:, :, 0]
        condition[:, i] = np.linalg.cond(design)
        explained = np.einsum("fl,flm,fm->f", target.conj(), rr_inv, target).real
        coherence[:, i] = np.clip(explained / np.maximum(spectra.yy[:, i], 1e-300), 0.0, 1.0)
    return PmrEstimate(spectra.omega, ratio, coherence, condition, spectra.segments)


def estimate_pmr(
    r: np.ndarray, u: np.ndarray, y: np.ndarray, *, model: FoptdMatrix, welch: WelchSettings
) -> PmrEstimate:
    """The implicit MIMO PMR estimate (eq. 13) from closed-loop records.

    Parameters
    ----------
    r : ndarray, shape (N, n_outputs)
        Setpoints [output unit].
    u : ndarray, shape (N, n_inputs)
        Manipulated inputs [input unit].
    y : ndarray, shape (N, n_outputs)
        Measured outputs [output unit].
    model : FoptdMatrix
        The controller's model ``Ghat``.
    welch : WelchSettings

    Raises
    ------
    InsufficientData
        The record cannot support an estimate (see :func:`~pmr_ros.core.record.check_record`).
    """
    r, u, y = (np.asarray(a, dtype=float) for a in (r, u, y))
    check_record(r, u, y, model=model, welch=welch)
    return implicit_estimate(record_spectra(r, u, y, model, welch))
