"""The PMR engine: exactness without noise, insufficient data, and the paper's baseline."""

from dataclasses import replace
from functools import cache

import numpy as np
import pytest

from pmr_ros.config import load_config
from pmr_ros.core.pmr.checks import InsufficientData, check_record, check_stretches
from pmr_ros.core.pmr.classic import diagnose_classic
from pmr_ros.core.pmr.implicit import estimate_pmr
from pmr_ros.core.records import Record
from pmr_ros.core.results.codec import diagnosis_to_json
from pmr_ros.core.sim.batch import simulate_many
from pmr_ros.core.sim.closed_loop import simulate


def diagnose(r, u, y, model, settings):
    return diagnose_classic([Record(r, u, y)], model=model, settings=settings)


SEEDS = range(1, 6)


def test_noise_free_pmr_with_plant_equal_to_model_is_one_with_zero_delay():
    config = load_config(overrides={"noise": {"std": 0.0}, "run": {"scenario": "none"}})
    rec = simulate(config, samples=8192)
    estimate = estimate_pmr([Record(rec.r, rec.u, rec.y)], model=config.model, welch=config.pmr.welch)
    informative = estimate.omega <= 1.0
    np.testing.assert_allclose(estimate.ratio[informative], 1.0, atol=1e-3)
    diagnosis = diagnose(rec.r, rec.u, rec.y, config.model, config.pmr)
    for element in diagnosis.elements.values():
        assert element.classic.gain_ratio == pytest.approx(1.0, abs=1e-3)
        assert abs(element.classic.tau_index) < 0.5
        assert element.classic.delay_mismatch_samples == 0
        assert element.verdict == "ok"


def test_noise_free_pmr_equals_the_true_ratio_under_mismatch():
    config = load_config(overrides={"noise": {"std": 0.0}})
    rec = simulate(config, samples=8192, scenario="full")
    estimate = estimate_pmr([Record(rec.r, rec.u, rec.y)], model=config.model, welch=config.pmr.welch)
    w = estimate.omega[estimate.omega <= 0.4]
    truth = config.plant("full").discretize().frequency_response(w) / config.model.discretize().frequency_response(w)
    np.testing.assert_allclose(estimate.ratio[: w.size], np.moveaxis(truth, -1, 0), rtol=0.02, atol=0.02)


@cache
def _baseline_runs(path, scenario):
    """``scenario`` x 5 seeds on the configuration at ``path``, diagnosed (simulated in lockstep, once per process).

    One small piece per system and scenario, so that the parallel test workers share the work out.
    """
    config = load_config(path)
    records = simulate_many(config, [(scenario, seed) for seed in SEEDS])
    return {
        seed: diagnosis_to_json(diagnose(rec.r, rec.u, rec.y, config.model, config.pmr))
        for seed, rec in zip(SEEDS, records, strict=True)
    }


def _matrix(d, key, n):
    return np.array([d["elements"][name]["classic"][key] for name in d["elements"]], dtype=float).reshape(n, n)


def test_full_mismatch_reproduces_section_3_3_on_wood_berry(wood_berry):
    for d in _baseline_runs(None, "full").values():
        assert d["status"] == "ok"
        np.testing.assert_allclose(_matrix(d, "gain_ratio", 2), [[1.10, 1.15], [0.85, 0.90]], atol=0.03)
        np.testing.assert_array_equal(np.sign(_matrix(d, "tau_index", 2)), [[1, 1], [-1, -1]])
        np.testing.assert_array_equal(_matrix(d, "delay_mismatch_samples", 2), [[0, 1], [2, 0]])
        assert all(e["verdict"] == "mismatch" for e in d["elements"].values())


@pytest.mark.parametrize("path", [None, "config/three_by_three.yaml"], ids=["wood_berry", "3x3"])
@pytest.mark.parametrize("scenario", ["none", "gain", "time_constant", "delay", "full"])
def test_each_scenario_flags_exactly_its_own_parameters(path, scenario):
    config = load_config(path)
    n = config.model.n_outputs
    injected = config.mismatch.for_scenario(scenario)
    for seed, d in _baseline_runs(path, scenario).items():
        assert d["status"] == "ok"
        np.testing.assert_array_equal(
            _matrix(d, "gain_mismatch", n).astype(bool), injected.gain_pct != 0, err_msg=f"gain flags, seed {seed}"
        )
        np.testing.assert_array_equal(
            _matrix(d, "tau_mismatch", n).astype(bool),
            injected.time_constant_pct != 0,
            err_msg=f"tau flags, seed {seed}",
        )
        np.testing.assert_array_equal(
            _matrix(d, "delay_mismatch", n).astype(bool),
            injected.delay_samples != 0,
            err_msg=f"delay flags, seed {seed}",
        )
        np.testing.assert_allclose(
            _matrix(d, "gain_ratio", n), injected.gain_ratio, atol=0.03, err_msg=f"gain ratios, seed {seed}"
        )
        np.testing.assert_array_equal(
            _matrix(d, "delay_mismatch_samples", n), injected.delay_samples, err_msg=f"delays, seed {seed}"
        )
        tau = _matrix(d, "tau_index", n)
        moved = injected.time_constant_pct != 0
        np.testing.assert_array_equal(
            np.sign(tau[moved]), np.sign(injected.time_constant_pct[moved]), err_msg=f"tau signs, seed {seed}"
        )


def test_constant_setpoints_are_insufficient_data(wood_berry):
    config = load_config(overrides={"prbs": {"amplitude": 0.0}})
    rec = simulate(config, samples=4096)
    d = diagnose(rec.r, rec.u, rec.y, config.model, config.pmr)
    assert d.status == "insufficient_data" and "no excitation" in d.reason
    assert all(e.classic is None and e.verdict == "inconclusive" for e in d.elements.values())
    assert d.elements["G11"].summary().startswith("insufficient data: no excitation")
    assert diagnosis_to_json(d)["elements"]["G11"]["reasons"] == [d.reason]


def test_one_constant_setpoint_is_no_instrument_and_the_reason_says_what_to_add():
    config = load_config(overrides={"prbs": {"amplitude": [1.0, 0.0]}})
    rec = simulate(config, samples=4096)
    d = diagnose(rec.r, rec.u, rec.y, config.model, config.pmr)
    # one instrument for two inputs: the classic method reads no row, and says what would add one
    assert d.status == "insufficient_data" and "is constant" not in d.reason
    assert "2 modeled inputs but 1 instrument" in d.reason and "a setpoint change on y2 (x_B)" in d.reason


def test_too_short_a_record_is_insufficient_data(wood_berry):
    rec = simulate(wood_berry, samples=1000)
    d = diagnose(rec.r, rec.u, rec.y, wood_berry.model, wood_berry.pmr)
    assert d.status == "insufficient_data" and "too short" in d.reason


def test_check_record_rejects_nan_and_wrong_shapes(wood_berry):
    rec = simulate(wood_berry, samples=3000)
    y = rec.y.copy()
    y[100, 1] = np.nan
    with pytest.raises(InsufficientData, match="NaN"):
        check_record(rec.r, rec.u, y, model=wood_berry.model, welch=wood_berry.pmr.welch)
    with pytest.raises(InsufficientData, match="shape"):
        check_record(rec.r, rec.u[:, :1], rec.y, model=wood_berry.model, welch=wood_berry.pmr.welch)
    with pytest.raises(InsufficientData, match="lengths"):
        check_record(rec.r, rec.u[:-1], rec.y, model=wood_berry.model, welch=wood_berry.pmr.welch)
    check_record(rec.r, rec.u, rec.y, model=wood_berry.model, welch=wood_berry.pmr.welch)  # a good record passes


def test_a_record_with_gaps_gives_one_estimate_from_all_its_stretches(wood_berry):
    """Welch segments are averaged over every stretch: twelve pieces give the whole record's diagnosis."""
    config = load_config(overrides={"noise": {"std": 0.0}})
    rec = simulate(config, samples=16384)
    whole = diagnose(rec.r, rec.u, rec.y, config.model, config.pmr)
    cuts = np.linspace(0, 16384, 5).astype(int)
    pieces = [Record(rec.r[a:b], rec.u[a:b], rec.y[a:b]) for a, b in zip(cuts[:-1], cuts[1:], strict=True)]
    split = diagnose_classic(pieces, model=config.model, settings=config.pmr)
    assert split.status == "ok" and split.samples == 16384
    for name, element in whole.elements.items():
        # noise-free: each piece sees the same ratio; gains agree to the leakage of the extra start-ups
        assert split.elements[name].classic.gain_ratio == pytest.approx(element.classic.gain_ratio, abs=0.01), name
        assert split.elements[name].classic.delay_mismatch_samples == element.classic.delay_mismatch_samples
    too_short = [Record(rec.r[:300], rec.u[:300], rec.y[:300])] * 3
    with pytest.raises(InsufficientData, match="in 3 stretches"):
        check_stretches(too_short, model=config.model, welch=config.pmr.welch)


def test_mv_dither_joins_the_setpoints_as_instruments(wood_berry):
    from pmr_ros.core.pmr.spectra import record_spectra
    from pmr_ros.core.sim.excitation import ExcitationSettings

    config = replace(wood_berry, excitation=ExcitationSettings(np.array([0.3, 0.0]), 4))
    rec = simulate(config, samples=8192)
    spectra = record_spectra([Record(rec.r, rec.u, rec.y, rec.dither)], config.model, config.pmr.welch)
    assert spectra.rr.shape[1:] == (3, 3)  # r1, r2 and the dither of u1 (u2's is still: not an instrument)
    plain = record_spectra([Record(rec.r, rec.u, rec.y)], config.model, config.pmr.welch)
    np.testing.assert_allclose(spectra.rr[:, :2, :2], plain.rr)
