"""One entry point for every diagnosis method."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from .classic import PmrSettings, diagnose_classic
from .foptd import FoptdMatrix
from .parametric import ParametricSettings, diagnose_parametric
from .results import Diagnosis

__all__ = ["METHODS", "diagnose"]


def _classic(
    r: np.ndarray, u: np.ndarray, y: np.ndarray, *, model: FoptdMatrix, pmr: PmrSettings, parametric: ParametricSettings
) -> Diagnosis:
    return diagnose_classic(r, u, y, model=model, settings=pmr)


def _parametric(
    r: np.ndarray, u: np.ndarray, y: np.ndarray, *, model: FoptdMatrix, pmr: PmrSettings, parametric: ParametricSettings
) -> Diagnosis:
    return diagnose_parametric(r, u, y, model=model, classic=pmr, settings=parametric)


METHODS: dict[str, Callable[..., Diagnosis]] = {"classic": _classic, "parametric": _parametric}
"""Diagnosis methods by name: the paper's Table 1, or the FOPTD-ratio fit of :mod:`pmr_ros.core.parametric`."""


def diagnose(
    r: np.ndarray,
    u: np.ndarray,
    y: np.ndarray,
    *,
    model: FoptdMatrix,
    pmr: PmrSettings,
    parametric: ParametricSettings,
    method: str | None = None,
) -> Diagnosis:
    """Diagnose a record with ``method`` (default ``pmr.method``).

    Parameters
    ----------
    r, u, y : ndarray
        Setpoints, inputs and measured outputs, one row per sample.
    model : FoptdMatrix
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
    return METHODS[method](r, u, y, model=model, pmr=pmr, parametric=parametric)
