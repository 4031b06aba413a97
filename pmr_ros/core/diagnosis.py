"""One entry point for every diagnosis method."""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np

from .classic import PmrSettings, diagnose_classic
from .model import TransferMatrix
from .parametric import ParametricSettings, diagnose_parametric
from .results import Diagnosis
from .stretch import Stretch

__all__ = ["METHODS", "diagnose", "diagnose_stretches"]


def _classic(
    stretches: Sequence[Stretch], *, model: TransferMatrix, pmr: PmrSettings, parametric: ParametricSettings
) -> Diagnosis:
    return diagnose_classic(stretches, model=model, settings=pmr)


def _parametric(
    stretches: Sequence[Stretch], *, model: TransferMatrix, pmr: PmrSettings, parametric: ParametricSettings
) -> Diagnosis:
    return diagnose_parametric(stretches, model=model, classic=pmr, settings=parametric)


METHODS: dict[str, Callable[..., Diagnosis]] = {"classic": _classic, "parametric": _parametric}
"""Diagnosis methods by name: the paper's Table 1, or the FOPTD-ratio fit of :mod:`pmr_ros.core.parametric`."""


def diagnose_stretches(
    stretches: Sequence[Stretch],
    *,
    model: TransferMatrix,
    pmr: PmrSettings,
    parametric: ParametricSettings,
    method: str | None = None,
) -> Diagnosis:
    """Diagnose unbroken stretches of data (one estimate from all of them) with ``method`` (default ``pmr.method``).

    Parameters
    ----------
    stretches : sequence of Stretch
        Setpoints, inputs, outputs and (if any) MV dither of each stretch.
    model : TransferMatrix
        The controller's model ``Ghat``.
    pmr : PmrSettings
        Spectral settings and the classic thresholds.
    parametric : ParametricSettings
    method : str, optional
        A key of :data:`METHODS`.

    Raises
    ------
    ValueError
        For an unknown method.
    """
    method = method or pmr.method
    if method not in METHODS:
        raise ValueError(f"unknown diagnosis method {method!r}; choose one of {', '.join(METHODS)}")
    return METHODS[method](list(stretches), model=model, pmr=pmr, parametric=parametric)


def diagnose(
    r: np.ndarray,
    u: np.ndarray,
    y: np.ndarray,
    *,
    model: TransferMatrix,
    pmr: PmrSettings,
    parametric: ParametricSettings,
    method: str | None = None,
    dither: np.ndarray | None = None,
) -> Diagnosis:
    """Diagnose one gap-free record with ``method`` (default ``pmr.method``).

    Parameters
    ----------
    r, u, y : ndarray
        Setpoints, inputs and measured outputs, one row per sample.
    model : TransferMatrix
        The controller's model ``Ghat``.
    pmr : PmrSettings
        Spectral settings and the classic thresholds.
    parametric : ParametricSettings
    method : str, optional
        A key of :data:`METHODS`.
    dither : ndarray, shape (N, n_inputs), optional
        The MV dither added to the controller's outputs; its moving columns
        join the setpoints as instruments.

    Raises
    ------
    ValueError
        For an unknown method.
    """
    stretch = Stretch(np.asarray(r), np.asarray(u), np.asarray(y), None if dither is None else np.asarray(dither))
    return diagnose_stretches([stretch], model=model, pmr=pmr, parametric=parametric, method=method)
