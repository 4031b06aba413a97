"""The measured disturbances (DVs) as inputs of the model and of the data: ``[G, Gd]`` and the record to match.

A DV is an input that is always external, like an MV whose controller is
always off: the diagnosis runs on the augmented model (:func:`augmented_model`,
its DV elements named ``D11`` ...) and the augmented record
(:func:`augmented_record`: the DVs as inputs always in manual, so each is its
own instrument).  :func:`process_part` and :func:`disturbance_part` split an
augmented model again (the MPC acts on ``G`` only).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from ..records import Record
from .model import TransferMatrix

__all__ = [
    "augmented_model",
    "augmented_record",
    "disturbance_part",
    "missing_disturbances",
    "process_part",
    "with_disturbances",
]


def augmented_model(model: TransferMatrix, disturbance_model: TransferMatrix | None) -> TransferMatrix:
    """``[G, Gd]``: the controller's model with its measured disturbances' feedforward model as the last inputs.

    Parameters
    ----------
    model : TransferMatrix
        ``G``, n_outputs x n_inputs (without DVs).
    disturbance_model : TransferMatrix or None
        ``Gd``, n_outputs x n_disturbances, its input names the DV names
        (``PmrConfig.disturbance_model``); None: ``model`` itself.

    Returns
    -------
    TransferMatrix
        n_outputs x (n_inputs + n_disturbances) with ``n_disturbances`` set:
        its DV elements are named ``D11`` ...

    Raises
    ------
    ValueError
        ``Gd``'s outputs or sample time are not ``G``'s, or ``model`` has DVs already.

    Examples
    --------
    >>> g = TransferMatrix([[1.0, 2.0]], [[5.0, 6.0]], [[0.0, 1.0]], 1.0)
    >>> gd = TransferMatrix([[0.5]], [[4.0]], [[2.0]], 1.0, input_names=("feed",))
    >>> augmented_model(g, gd).element_names()
    ['G11', 'G12', 'D11']
    """
    if disturbance_model is None:
        return model
    if model.n_disturbances:
        raise ValueError(f"the model has {model.n_disturbances} DV columns already")
    if disturbance_model.n_outputs != model.n_outputs or disturbance_model.sample_time != model.sample_time:
        raise ValueError(
            f"the disturbance model ({disturbance_model.n_outputs} outputs, Ts {disturbance_model.sample_time:g}) "
            f"does not match the model ({model.n_outputs} outputs, Ts {model.sample_time:g})"
        )
    if model.has_general or disturbance_model.has_general:  # the elements themselves, side by side
        return TransferMatrix.of_elements(
            [[*g, *gd] for g, gd in zip(model.element_rows(), disturbance_model.element_rows(), strict=True)],
            sample_time=model.sample_time,
            output_names=model.output_names,
            input_names=(*model.input_names, *disturbance_model.input_names),
            name=model.name,
            n_disturbances=disturbance_model.n_inputs,
        )
    return TransferMatrix(
        np.hstack([model.gain, disturbance_model.gain]),
        np.hstack([model.time_constant, disturbance_model.time_constant]),
        np.hstack([model.delay, disturbance_model.delay]),
        model.sample_time,
        output_names=model.output_names,
        input_names=(*model.input_names, *disturbance_model.input_names),
        name=model.name,
        element_type=np.hstack([model.element_type, disturbance_model.element_type]),
        n_disturbances=disturbance_model.n_inputs,
    )


def _columns(model: TransferMatrix, columns: slice, n_disturbances: int) -> TransferMatrix:
    if model.has_general:
        return TransferMatrix.of_elements(
            [row[columns] for row in model.element_rows()],
            sample_time=model.sample_time,
            output_names=model.output_names,
            input_names=model.input_names[columns],
            name=model.name,
            n_disturbances=n_disturbances,
        )
    return TransferMatrix(
        model.gain[:, columns],
        model.time_constant[:, columns],
        model.delay[:, columns],
        model.sample_time,
        output_names=model.output_names,
        input_names=model.input_names[columns],
        name=model.name,
        element_type=model.element_type[:, columns],
        n_disturbances=n_disturbances,
    )


def process_part(model: TransferMatrix) -> TransferMatrix:
    """``G`` of an augmented model ``[G, Gd]``: the MV columns (the model itself without DVs)."""
    if not model.n_disturbances:
        return model
    return _columns(model, slice(0, model.n_inputs - model.n_disturbances), 0)


def disturbance_part(model: TransferMatrix) -> TransferMatrix | None:
    """``Gd`` of an augmented model ``[G, Gd]``: the DV columns; None without DVs."""
    if not model.n_disturbances:
        return None
    return _columns(model, slice(model.n_inputs - model.n_disturbances, None), 0)


def augmented_record(record: Record, n_disturbances: int) -> Record:
    """A record whose measured disturbances are inputs that are always in manual: it matches :func:`augmented_model`.

    ``u = [u, dv]``, ``manual = [manual (False where not given), True for the DV
    columns]``, ``dither`` padded with zeros; ``dv`` is then None (it is in ``u``).

    Parameters
    ----------
    record : Record
        With ``dv`` of ``n_disturbances`` columns.
    n_disturbances : int
        The DVs of the model (0: ``record`` itself).

    Raises
    ------
    ValueError
        ``record.dv`` is missing or not of ``n_disturbances`` columns.
    """
    if n_disturbances == 0:
        return record
    dv = None if record.dv is None else np.asarray(record.dv, dtype=float)
    if dv is None or dv.ndim != 2 or dv.shape[1] != n_disturbances:
        found = "no dv" if dv is None else f"dv of shape {dv.shape}"
        raise ValueError(f"the model has {n_disturbances} measured disturbances, the record {found}")
    u = np.asarray(record.u, dtype=float)
    manual = np.zeros(u.shape, dtype=bool) if record.manual is None else np.asarray(record.manual, dtype=bool)
    dither = None if record.dither is None else np.hstack([np.asarray(record.dither, dtype=float), np.zeros(dv.shape)])
    return Record(
        record.r,
        np.hstack([u, dv]),
        record.y,
        dither=dither,
        manual=np.hstack([manual, np.ones(dv.shape, dtype=bool)]),
    )


def missing_disturbances(stretches: Sequence[Record], disturbance_model: TransferMatrix | None) -> str | None:
    """Why the data cannot be diagnosed with the measured disturbances of ``disturbance_model``, or None.

    One line: the configuration names DVs and a stretch carries no ``dv`` of
    that many columns.

    Examples
    --------
    >>> gd = TransferMatrix([[0.5]], [[4.0]], [[2.0]], 1.0, input_names=("feed",))
    >>> missing_disturbances([Record(np.zeros((3, 1)), np.zeros((3, 1)), np.zeros((3, 1)))], gd)[:52]
    'the configuration has 1 measured disturbance (feed) '
    """
    if disturbance_model is None:
        return None
    n_dv = disturbance_model.n_inputs
    for s in stretches:
        if s.dv is None or np.ndim(s.dv) != 2 or np.shape(s.dv)[1] != n_dv:
            found = "none" if s.dv is None else f"dv of shape {np.shape(s.dv)}"
            return (
                f"the configuration has {n_dv} measured disturbance{'s' if n_dv > 1 else ''} "
                f"({', '.join(disturbance_model.input_names)}) but the data carry {found}: "
                "give their columns (data.disturbance_columns) or remove system.disturbance_names"
            )
    return None


def with_disturbances(
    stretches: Sequence[Record], model: TransferMatrix, disturbance_model: TransferMatrix | None
) -> tuple[list[Record], TransferMatrix]:
    """The stretches and the model a diagnosis runs on: augmented when the configuration has DVs.

    Raises
    ------
    ValueError
        The data lack the DVs (:func:`missing_disturbances`' line).
    """
    problem = missing_disturbances(stretches, disturbance_model)
    if problem:
        raise ValueError(problem)
    if disturbance_model is None:
        return list(stretches), model
    n_dv = disturbance_model.n_inputs
    return [augmented_record(s, n_dv) for s in stretches], augmented_model(model, disturbance_model)
