"""Never confidently wrong on hard systems; the reference cases stay decisive.

A reduced run of ``benchmarks/bench_hard_cases.py`` (which prints the full
figures over 20 seeds): on the Ogunnaike-Ray column, whose MPC moves u1 and
u2 together, on the ill-conditioned Skogestad LV column and on a model with a
~0 gain, the confidently wrong parameter
verdicts stay within a 5 % rate and the intervals of the decisive ones cover
the truth at a 90 % rate (binomial bounds, test/binomial.py).  On Wood-Berry
with the paper's mismatch every verdict stays decisive and right.
"""

from __future__ import annotations

import numpy as np
import pytest
from binomial import max_failures, min_successes
from hard_cases import CASES, Score, run, score

from pmr_ros.core.pmr.diagnosis import diagnose
from pmr_ros.core.sim.closed_loop import simulate

SEEDS = range(1, 5)


@pytest.mark.parametrize("name", ["ogunnaike_ray", "skogestad_lv", "near_zero_gain"])
@pytest.mark.parametrize("mismatch", [False, True], ids=["none", "full"])
def test_no_confidently_wrong_verdicts_and_calibrated_intervals_on_hard_cases(name, mismatch):
    case = CASES[name]
    config = case.config()
    total = Score()
    for seed in SEEDS:
        total.add(score(run(case, seed, mismatch=mismatch, config=config), config, mismatch=mismatch))
    assert total.wrong <= max_failures(total.verdicts, 0.05), total.wrong_examples
    assert total.covered >= min_successes(total.intervals, 0.90)
    assert total.inconclusive < total.verdicts / 2  # not a monitor that always says "cannot tell"


def test_inputs_moved_together_are_named_with_the_dither_to_add():
    case = CASES["ogunnaike_ray"]
    config = case.config()
    reasons = [
        reason
        for seed in SEEDS
        for element in run(case, seed, mismatch=True, config=config).elements.values()
        for reason in element.parametric.reasons
    ]
    apart = [r for r in reasons if "cannot be told apart" in r]
    dither = ("add MV dither on u1 or u2 (excitation", "add MV dither on u2 or u1 (excitation")
    assert apart and all(any(d in r for d in dither) for r in apart)
    assert any(r.startswith("u1 and u2 move together in the fitted band") for r in apart)


def test_a_model_gain_of_about_zero_is_called_the_models_and_the_rest_is_diagnosed():
    case = CASES["near_zero_gain"]
    config = case.config()
    diagnosis = run(case, 1, mismatch=False, config=config)
    assert diagnosis.status == "ok"
    g12 = diagnosis.elements["G12"].parametric
    assert g12.verdict == "inconclusive"
    assert g12.reasons == (
        "G12's model gain 1e-06 is ~0 (below 0.0001 of the row's largest): its filtered input carries no "
        "information; treat it as an empty cell (element_type none)",
    )
    decided = [e.verdict for name, e in diagnosis.elements.items() if name != "G12"]
    assert decided.count("inconclusive") == 0


def test_wood_berry_full_scenario_verdicts_stay_decisive_and_right(wood_berry):
    truth = wood_berry.mismatch
    for seed in (1, 2, 3):
        record = simulate(wood_berry, seed=seed, scenario="full")
        diagnosis = diagnose(
            record.r, record.u, record.y, model=wood_berry.model, pmr=wood_berry.pmr, parametric=wood_berry.parametric
        )
        for element in diagnosis.elements.values():
            p, i, k = element.parametric, element.row, element.column
            assert p.reasons == (), (seed, element.name)
            assert (p.gain_verdict, p.tau_verdict, p.delay_verdict) == (
                "mismatch",
                "mismatch",
                "mismatch" if truth.delay_samples[i, k] else "ok",
            ), (seed, element.name)
            assert p.delay_mismatch_samples == truth.delay_samples[i, k]


def test_the_lv_columns_estimates_are_not_biased_by_the_welch_segments_leakage():
    """The LV column's row 1 is not biased by the Welch segments' leakage.

    Every parameter was 0.6-1.4 pp low (one to two deviations; coverage 83 %) before the leakage
    correction (parametric.fit.leakage_offset); the mean error in deviations is now small.
    """
    case = CASES["skogestad_lv"]
    config = case.config()
    truth = config.mismatch.for_scenario("full")
    errors = []
    for seed in range(1, 7):
        diagnosis = run(case, seed, mismatch=True, config=config)
        for name in ("G11", "G12"):
            p, k = diagnosis.elements[name].parametric, diagnosis.elements[name].column
            for value, interval, injected in (
                (p.gain_mismatch_pct, p.gain_mismatch_pct_interval, truth.gain_pct[0, k]),
                (p.tau_mismatch_pct, p.tau_mismatch_pct_interval, truth.time_constant_pct[0, k]),
            ):
                errors.append((value - injected) / ((interval[1] - interval[0]) / 3.92))
    # 24 errors in deviations, correlated within a seed: their mean was -1.4 before, about -0.35 after
    assert abs(np.mean(errors)) < 0.8, np.round(errors, 2)
