"""One entry point for every diagnosis method."""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np

from .classic import PmrSettings, diagnose_classic
from .model import TransferMatrix
from .parametric import ParametricSettings, diagnose_parametric
from .results import Diagnosis
from .spectra import WelchSettings
from .stretch import Stretch

__all__ = ["METHODS", "diagnose", "diagnose_stretches", "shortest_useful_stretch", "useful_stretches"]


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


def _welch(
    stretches: Sequence[Stretch],
    *,
    model: TransferMatrix,
    pmr: PmrSettings,
    parametric: ParametricSettings,
    method: str | None = None,
) -> WelchSettings:
    """The Welch segments ``method`` would average over ``stretches`` (the parametric one depends on the longest)."""
    if (method or pmr.method) == "parametric":
        return parametric.welch(model, max((s.samples for s in stretches), default=0), pmr)
    return pmr.welch


def shortest_useful_stretch(
    stretches: Sequence[Stretch],
    *,
    model: TransferMatrix,
    pmr: PmrSettings,
    parametric: ParametricSettings,
    method: str | None = None,
) -> int:
    """Fewest samples with which a stretch adds a Welch segment: the model's settling plus one segment [samples].

    Parameters
    ----------
    stretches : sequence of Stretch
        The data (the parametric method sizes its segment from the longest stretch).
    model : TransferMatrix
        The controller's model ``Ghat`` (its settling is dropped from every stretch).
    pmr : PmrSettings
    parametric : ParametricSettings
    method : str, optional
        A key of :data:`METHODS` (default ``pmr.method``).
    """
    welch = _welch(stretches, model=model, pmr=pmr, parametric=parametric, method=method)
    return model.settling_samples() + welch.segment_length


def useful_stretches(
    stretches: Sequence[Stretch],
    *,
    model: TransferMatrix,
    pmr: PmrSettings,
    parametric: ParametricSettings,
    method: str | None = None,
) -> list[Stretch]:
    """The stretches that add at least one Welch segment to a diagnosis with ``method``; shorter ones add nothing.

    Parameters
    ----------
    stretches : sequence of Stretch
    model : TransferMatrix
    pmr : PmrSettings
    parametric : ParametricSettings
    method : str, optional
        A key of :data:`METHODS` (default ``pmr.method``).
    """
    shortest = shortest_useful_stretch(stretches, model=model, pmr=pmr, parametric=parametric, method=method)
    return [s for s in stretches if s.samples >= shortest]


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
