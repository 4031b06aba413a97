"""Singular and nearly singular models: never a confident ``mismatch`` (pmr_ros.core.pmr.parametric.rank)."""

from functools import cache

import numpy as np

from pmr_ros.config import load_config
from pmr_ros.core.pmr.parametric import diagnose_parametric
from pmr_ros.core.pmr.parametric.lsq import RowParameters
from pmr_ros.core.pmr.parametric.rank import collinear_inputs_reason, nominal_start
from pmr_ros.core.pmr.parametric.ratio import ColumnModel
from pmr_ros.core.records import Record
from pmr_ros.core.sim.batch import simulate_many

SEEDS = range(1, 11)
SINGULAR = [1.0, 1.0, 1.0, 1.0]
"""Rank one: the MPC moves both inputs alike (their correlation 0.9995)."""
NEARLY_SINGULAR = [1.0, 1.0, 1.0, 1.0005]
"""Condition number of the gain matrix 8000 (> 1e3)."""


@cache
def _verdicts(gain: tuple[float, ...]):
    """Per seed, each element's parametric verdict and reasons on a no-mismatch run of the model with ``gain``.

    Computed once per process and gain matrix, so that the parallel test workers share the two campaigns out.
    """
    config = load_config(overrides={"system": {"gain": list(gain)}})
    out = []
    for record in simulate_many(config, [("none", s) for s in SEEDS], samples=8192):
        stretch = Record(record.r, record.u, record.y, record.dither)
        diagnosis = diagnose_parametric([stretch], model=config.model, classic=config.pmr, settings=config.parametric)
        out.append({name: (e.verdict, e.parametric.reasons) for name, e in diagnosis.elements.items()})
    return out


def test_gain_matrices_are_as_named():
    assert np.linalg.matrix_rank(np.reshape(SINGULAR, (2, 2))) == 1
    assert np.linalg.cond(np.reshape(NEARLY_SINGULAR, (2, 2))) > 1e3


def test_a_rank_one_model_without_mismatch_is_inconclusive_with_the_reason_on_every_seed():
    for run in _verdicts(tuple(SINGULAR)):
        for name, (verdict, reasons) in run.items():
            assert verdict == "inconclusive", (name, verdict)
            assert any("fewer independent directions than the row has elements" in r for r in reasons), reasons


def test_a_nearly_singular_model_without_mismatch_never_gives_a_mismatch():
    verdicts = [verdict for run in _verdicts(tuple(NEARLY_SINGULAR)) for verdict, _ in run.values()]
    assert len(verdicts) == 4 * len(SEEDS)
    assert "mismatch" not in verdicts


def test_the_nominal_start_is_the_model_itself_and_keeps_interactions():
    ratio = ColumnModel("ratio", 0.9, 10.0, (-1.0, 1.0), (-3, 3), True)
    lag = ColumnModel("lag", 0.0, 10.0, (-1.0, 1.0), (0, 5), False)
    swept = RowParameters(np.array([1.4, 0.2]), np.array([0.3, -0.1]), np.array([2, 4]))
    start = nominal_start([ratio, lag], swept)
    assert start is not None
    np.testing.assert_allclose(start.lin, [1.0, 0.2], rtol=0, atol=0)
    np.testing.assert_allclose(start.s, [0.0, -0.1], rtol=0, atol=0)
    assert start.delays.tolist() == [0, 4]
    assert nominal_start([lag], swept) is None


def test_the_reason_names_the_inputs_and_the_threshold():
    reason = collinear_inputs_reason(np.inf, max_condition=300.0, inputs=["reflux", "steam"])
    assert reason.startswith("ill-conditioned row regression (condition inf > parametric.max_condition 300)")
    assert "reflux, steam" in reason
