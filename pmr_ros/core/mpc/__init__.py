"""The model predictive controller: offline design, the QP, the disturbance estimator, loop stability.

``controller`` the linear constrained MPC, ``design`` its predictions and
condensed QP, ``qp`` the dense active-set solver, ``estimator`` the output
disturbance model, ``stability`` the unconstrained loop's spectral radius.

The names below are imported when first used, so importing one module of
this package does not load the others.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from ..._lazy import lazy_exports

_WHERE = {
    "CondensedQp": "design",
    "DenseQp": "qp",
    "DisturbanceEstimator": "estimator",
    "HISTORY_TIME_CONSTANTS": "controller",
    "LinearMpc": "controller",
    "MpcMatrices": "controller",
    "MpcStatistics": "controller",
    "MpcTuning": "controller",
    "QpSolution": "qp",
    "QpWeights": "design",
    "closed_loop_matrix": "stability",
    "condensed_qp": "design",
    "input_target_penalty": "design",
    "loop_spectral_radius": "stability",
    "neutral_modes": "stability",
    "null_space": "design",
    "prediction_matrices": "controller",
    "ramp_filter_gains": "estimator",
    "setpoints_reachable": "design",
    "steady_state_gain": "design",
    "target_map": "design",
}
"""Each public name -> the module of this package that defines it."""

__all__ = [
    "CondensedQp",
    "DenseQp",
    "DisturbanceEstimator",
    "HISTORY_TIME_CONSTANTS",
    "LinearMpc",
    "MpcMatrices",
    "MpcStatistics",
    "MpcTuning",
    "QpSolution",
    "QpWeights",
    "closed_loop_matrix",
    "condensed_qp",
    "input_target_penalty",
    "loop_spectral_radius",
    "neutral_modes",
    "null_space",
    "prediction_matrices",
    "ramp_filter_gains",
    "setpoints_reachable",
    "steady_state_gain",
    "target_map",
]


__getattr__, __dir__ = lazy_exports(__name__, _WHERE, __all__)


if TYPE_CHECKING:
    from .controller import (
        HISTORY_TIME_CONSTANTS,
        LinearMpc,
        MpcMatrices,
        MpcStatistics,
        MpcTuning,
        prediction_matrices,
    )
    from .design import (
        CondensedQp,
        QpWeights,
        condensed_qp,
        input_target_penalty,
        null_space,
        setpoints_reachable,
        steady_state_gain,
        target_map,
    )
    from .estimator import DisturbanceEstimator, ramp_filter_gains
    from .qp import DenseQp, QpSolution
    from .stability import closed_loop_matrix, loop_spectral_radius, neutral_modes
