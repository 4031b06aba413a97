"""Simulation: the model and the true plant, setpoint excitation and dither, the closed loop in batch.

``model`` transfer matrices (FOPTD, integrating, empty elements), ``true_plant``
the simulated plant with noise and disturbances, ``excitation`` PRBS setpoints
and MV dither, ``closed_loop`` one run, ``batch`` many runs in lockstep,
``memory`` what a run needs before it is allocated.

The names below are imported when first used, so importing one module of
this package does not load the others.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from ..._lazy import lazy_exports

_WHERE = {
    "DIAGNOSIS_BYTES_PER_CHANNEL": "memory",
    "DiscreteFoptd": "model",
    "DisturbanceStream": "true_plant",
    "ExcitationSettings": "excitation",
    "FoptdPlant": "true_plant",
    "LockstepResult": "batch",
    "LoopConfig": "closed_loop",
    "Mismatch": "model",
    "OutputDisturbance": "true_plant",
    "PrbsGenerator": "excitation",
    "PrbsSettings": "excitation",
    "RunPlan": "closed_loop",
    "SIMULATION_BYTES_PER_VALUE": "memory",
    "StateSpace": "model",
    "TransferMatrix": "model",
    "WINDOW_BYTES_PER_SAMPLE": "memory",
    "WINDOW_BYTES_PER_VALUE": "memory",
    "available_bytes": "memory",
    "diagnosis_bytes": "memory",
    "disturbance_generator": "true_plant",
    "dither_generator": "excitation",
    "element_name": "model",
    "format_bytes": "memory",
    "is_primitive": "excitation",
    "m_sequence": "excitation",
    "noise_generator": "true_plant",
    "primitive_polynomial_count": "excitation",
    "primitive_polynomials": "excitation",
    "run_lockstep": "batch",
    "simulate": "closed_loop",
    "simulate_many": "batch",
    "simulation_bytes": "memory",
    "window_bytes": "memory",
    "worker_context": "batch",
}
"""Each public name -> the module of this package that defines it."""

__all__ = [
    "DIAGNOSIS_BYTES_PER_CHANNEL",
    "DiscreteFoptd",
    "DisturbanceStream",
    "ExcitationSettings",
    "FoptdPlant",
    "LockstepResult",
    "LoopConfig",
    "Mismatch",
    "OutputDisturbance",
    "PrbsGenerator",
    "PrbsSettings",
    "RunPlan",
    "SIMULATION_BYTES_PER_VALUE",
    "StateSpace",
    "TransferMatrix",
    "WINDOW_BYTES_PER_SAMPLE",
    "WINDOW_BYTES_PER_VALUE",
    "available_bytes",
    "diagnosis_bytes",
    "disturbance_generator",
    "dither_generator",
    "element_name",
    "format_bytes",
    "is_primitive",
    "m_sequence",
    "noise_generator",
    "primitive_polynomial_count",
    "primitive_polynomials",
    "run_lockstep",
    "simulate",
    "simulate_many",
    "simulation_bytes",
    "window_bytes",
    "worker_context",
]


__getattr__, __dir__ = lazy_exports(__name__, _WHERE, __all__)


if TYPE_CHECKING:
    from .batch import LockstepResult, run_lockstep, simulate_many, worker_context
    from .closed_loop import LoopConfig, RunPlan, simulate
    from .excitation import (
        ExcitationSettings,
        PrbsGenerator,
        PrbsSettings,
        dither_generator,
        is_primitive,
        m_sequence,
        primitive_polynomial_count,
        primitive_polynomials,
    )
    from .memory import (
        DIAGNOSIS_BYTES_PER_CHANNEL,
        SIMULATION_BYTES_PER_VALUE,
        WINDOW_BYTES_PER_SAMPLE,
        WINDOW_BYTES_PER_VALUE,
        available_bytes,
        diagnosis_bytes,
        format_bytes,
        simulation_bytes,
        window_bytes,
    )
    from .model import DiscreteFoptd, Mismatch, StateSpace, TransferMatrix, element_name
    from .true_plant import DisturbanceStream, FoptdPlant, OutputDisturbance, disturbance_generator, noise_generator
