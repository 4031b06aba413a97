"""Simulation: the model and the true plant, setpoint excitation and dither, the closed loop in batch.

``model`` transfer matrices (FOPTD, integrating, empty elements), ``true_plant``
the simulated plant with noise and disturbances, ``excitation`` PRBS setpoints
and MV dither, ``closed_loop`` one run, ``batch`` many runs in lockstep,
``memory`` and ``footprint`` what a run needs before it is allocated; elements of
any linear type (``lti``: FOPTD, integrating, empty; ``rational``: transfer
functions; ``step_curve``: step-response curves; ``elements`` builds one by
kind; ``realize`` one state-space system for a matrix of them); ``workers`` the
local worker processes that run many of them.

The names below are imported when first used, so importing one module of
this package does not load the others.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from ..._lazy import lazy_exports

_WHERE = {
    "DIAGNOSIS_BYTES_PER_CHANNEL": "memory",
    "DiscreteElement": "lti",
    "DiscreteFoptd": "model",
    "DisturbanceStream": "true_plant",
    "ELEMENT_KINDS": "elements",
    "Element": "lti",
    "ElementError": "lti",
    "Empty": "lti",
    "ExcitationSettings": "excitation",
    "Foptd": "lti",
    "FoptdPlant": "true_plant",
    "Integrating": "lti",
    "LockstepResult": "batch",
    "LoopConfig": "closed_loop",
    "Mismatch": "model",
    "OutputDisturbance": "true_plant",
    "PREDICTION_COPIES": "footprint",
    "PrbsGenerator": "excitation",
    "PrbsSettings": "excitation",
    "REALIZATION_COPIES": "footprint",
    "RunPlan": "closed_loop",
    "SIMULATION_BYTES_PER_VALUE": "memory",
    "StateSpace": "model",
    "StepResponse": "step_curve",
    "TransferFunction": "rational",
    "TransferMatrix": "model",
    "WINDOW_BYTES_PER_SAMPLE": "memory",
    "WINDOW_BYTES_PER_VALUE": "memory",
    "as_step_response": "step_curve",
    "available_bytes": "memory",
    "build_element": "elements",
    "controllable_form": "lti",
    "controller_bytes": "footprint",
    "dead_time_samples": "step_curve",
    "diagnosis_bytes": "memory",
    "disturbance_generator": "true_plant",
    "dither_generator": "excitation",
    "element_name": "model",
    "element_outputs": "realize",
    "format_bytes": "memory",
    "is_primitive": "excitation",
    "m_sequence": "excitation",
    "model_bytes": "footprint",
    "noise_generator": "true_plant",
    "parse_coefficients": "rational",
    "primitive_polynomial_count": "excitation",
    "primitive_polynomials": "excitation",
    "realization_bytes": "footprint",
    "run_lockstep": "batch",
    "planned_instruments": "footprint",
    "samples_needed": "footprint",
    "simulate": "closed_loop",
    "simulate_many": "batch",
    "simulation_bytes": "memory",
    "states": "footprint",
    "transfer_function": "rational",
    "window_bytes": "memory",
    "worker_context": "workers",
}
"""Each public name -> the module of this package that defines it."""

__all__ = [
    "DIAGNOSIS_BYTES_PER_CHANNEL",
    "DiscreteElement",
    "DiscreteFoptd",
    "DisturbanceStream",
    "ELEMENT_KINDS",
    "Element",
    "ElementError",
    "Empty",
    "ExcitationSettings",
    "Foptd",
    "FoptdPlant",
    "Integrating",
    "LockstepResult",
    "LoopConfig",
    "Mismatch",
    "OutputDisturbance",
    "PREDICTION_COPIES",
    "PrbsGenerator",
    "PrbsSettings",
    "REALIZATION_COPIES",
    "RunPlan",
    "SIMULATION_BYTES_PER_VALUE",
    "StateSpace",
    "StepResponse",
    "TransferFunction",
    "TransferMatrix",
    "WINDOW_BYTES_PER_SAMPLE",
    "WINDOW_BYTES_PER_VALUE",
    "as_step_response",
    "available_bytes",
    "build_element",
    "controllable_form",
    "controller_bytes",
    "dead_time_samples",
    "diagnosis_bytes",
    "disturbance_generator",
    "dither_generator",
    "element_name",
    "element_outputs",
    "format_bytes",
    "is_primitive",
    "m_sequence",
    "model_bytes",
    "noise_generator",
    "parse_coefficients",
    "planned_instruments",
    "primitive_polynomial_count",
    "primitive_polynomials",
    "realization_bytes",
    "run_lockstep",
    "samples_needed",
    "simulate",
    "simulate_many",
    "simulation_bytes",
    "states",
    "transfer_function",
    "window_bytes",
    "worker_context",
]


__getattr__, __dir__ = lazy_exports(__name__, _WHERE, __all__)


if TYPE_CHECKING:
    from .batch import LockstepResult, run_lockstep, simulate_many
    from .closed_loop import LoopConfig, RunPlan, simulate
    from .elements import ELEMENT_KINDS, build_element
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
    from .footprint import (
        PREDICTION_COPIES,
        REALIZATION_COPIES,
        controller_bytes,
        model_bytes,
        planned_instruments,
        realization_bytes,
        samples_needed,
        states,
    )
    from .lti import DiscreteElement, Element, ElementError, Empty, Foptd, Integrating, controllable_form
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
    from .rational import TransferFunction, parse_coefficients, transfer_function
    from .realize import element_outputs
    from .step_curve import StepResponse, as_step_response, dead_time_samples
    from .true_plant import DisturbanceStream, FoptdPlant, OutputDisturbance, disturbance_generator, noise_generator
    from .workers import worker_context
