"""Judging a live model update from the verdicts and the measured tracking of the windows before and after."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from pmr_ros.config import load_config
from pmr_ros.core.loop.adaptation import (
    Adaptation,
    AdaptSettings,
    TrackingFigures,
    judge_update,
    mismatch_size,
    tracking_figures,
)
from pmr_ros.core.results import Diagnosis, ElementDiagnosis, ElementModel, ParametricResult
from pmr_ros.core.results.codec import diagnosis_from_json

MODEL = ElementModel("foptd", 2.0, 10.0, 1)


def _diagnosis(**elements: ParametricResult) -> Diagnosis:
    return Diagnosis(
        "parametric",
        "ok",
        "",
        8192,
        {n: ElementDiagnosis(n, 0, j, MODEL, "parametric", parametric=p) for j, (n, p) in enumerate(elements.items())},
    )


def _result(dk: float, dtau: float, dd: int, *, verdicts: tuple[str, str, str]) -> ParametricResult:
    return ParametricResult(
        gain_mismatch_pct=dk,
        gain_mismatch_pct_interval=(dk - 1, dk + 1),
        tau_mismatch_pct=dtau,
        tau_mismatch_pct_interval=(dtau - 1, dtau + 1),
        delay_mismatch_samples=dd,
        delay_confidence=1.0,
        gain_verdict=verdicts[0],
        tau_verdict=verdicts[1],
        delay_verdict=verdicts[2],
    )


OK = ("ok", "ok", "ok")


def _figures(ise: float) -> TrackingFigures:
    return TrackingFigures(ise, 0.1, 0, 8191)


def test_tracking_figures_are_the_weighted_mean_squares():
    rng = np.random.default_rng(0)
    r, y, u = rng.normal(size=(100, 2)), rng.normal(size=(100, 2)), rng.normal(size=(100, 3))
    q, w = np.array([1.0, 2.0]), np.array([0.5, 1.0, 3.0])
    figures = tracking_figures(r, u, y, output_weight=q, move_weight=w, first_sample=7)
    np.testing.assert_allclose(figures.ise_per_sample, np.mean(q[0] * (r - y)[:, 0] ** 2 + q[1] * (r - y)[:, 1] ** 2))
    np.testing.assert_allclose(figures.input_movement_per_sample, np.mean((np.diff(u, axis=0) ** 2) @ w))
    assert (figures.first_sample, figures.last_sample) == (7, 106)


def test_mismatch_size_counts_only_mismatched_properties():
    d = _diagnosis(
        G11=_result(12.0, -30.0, 2, verdicts=("mismatch", "ok", "mismatch")),
        G12=_result(50.0, 50.0, 5, verdicts=("inconclusive", "inconclusive", "inconclusive")),
    )
    size = mismatch_size(d)
    assert (size.percent, size.delay_samples, size.elements) == (12.0, 2, ("G11",))
    assert mismatch_size(_diagnosis(G11=_result(1.0, 1.0, 0, verdicts=OK))).percent == 0.0


@pytest.mark.parametrize(
    ("after", "ise_after", "worse", "words"),
    [
        (_result(0.5, 0.2, 0, verdicts=OK), 1.9, False, ""),
        (_result(40.0, 0.2, 0, verdicts=("mismatch", "ok", "ok")), 1.9, True, "a larger mismatch: 40.0 %"),
        (_result(2.0, 0.2, 3, verdicts=("ok", "ok", "mismatch")), 1.9, True, "a larger delay mismatch: 3 samples"),
        (_result(0.5, 0.2, 0, verdicts=OK), 2.5 * 1.11, True, "the tracking error rose by 11.0 %"),
        (_result(0.5, 0.2, 0, verdicts=OK), 2.5 * 1.09, False, ""),
    ],
)
def test_an_update_is_worse_when_the_mismatch_grows_or_the_tracking_error_rises(after, ise_after, worse, words):
    before = _diagnosis(G11=_result(15.0, 10.0, 1, verdicts=("mismatch", "mismatch", "mismatch")))
    judgement = judge_update(
        before,
        _diagnosis(G11=after),
        tracking=(_figures(2.5), _figures(ise_after)),
        settings=AdaptSettings(ise_rise_tolerance_pct=10.0),
    )
    assert judgement.worse is worse
    assert (words in " ".join(judgement.reasons)) if words else judgement.reasons == ()


def test_the_adaptation_serialises_every_figure():
    config = load_config()
    before = _diagnosis(G11=_result(15.0, 10.0, 1, verdicts=("mismatch", "mismatch", "mismatch")))
    judgement = judge_update(before, before, tracking=(_figures(2.0), _figures(1.5)), settings=config.adapt)
    old = MODEL
    new = replace(MODEL, gain=2.3)
    out = Adaptation(before, (("G11", old, new),), 9000, (_figures(2.0), _figures(1.5)), judgement).to_dict()
    assert out["changes"] == [
        {
            "element": "G11",
            "before": {"kind": "foptd", "gain": 2.0, "time_constant": 10.0, "delay_samples": 1},
            "after": {"kind": "foptd", "gain": 2.3, "time_constant": 10.0, "delay_samples": 1},
        }
    ]
    assert out["tracking"]["ise_ratio"] == 0.75 and out["worse"] is False and not out["rolled_back"]
    assert diagnosis_from_json(out["before"]) == before
    assert config.adapt.ise_rise_tolerance_pct == 10.0


def test_an_adapted_run_is_three_windows_diagnosed_every_quarter():
    from pmr_ros.service.adapted_run import adapt_config, adapt_parameters

    config = load_config(overrides={"run": {"samples": 8192}})
    assert (
        adapt_config(config).run.samples == 3 * 8192
        and adapt_config(config).model.element_models() == config.model.element_models()
    )
    assert adapt_parameters(8192) == {
        "diagnostician.window_samples": 8192,
        "diagnostician.min_samples": 8192,
        "diagnostician.update_period_samples": 2048,
    }


@pytest.mark.parametrize(
    ("args", "words"),
    [(["--batch"], "cannot be used with --batch"), (["--method", "classic"], "needs the parametric method")],
)
def test_adapt_refuses_what_cannot_update_a_controller_in_one_line(capsys, args, words):
    from pmr_ros.cli import main

    assert main(["run", "--adapt", "--samples", "1024", *args]) == 2
    err = capsys.readouterr().err
    assert words in err and err.count("\n") == 1 and "Traceback" not in err
