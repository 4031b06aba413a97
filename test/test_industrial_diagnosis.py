"""Diagnosis of industrial shapes against injected truth: non-square, empty cells, integrating rows, MV dither.

Systems (built here, not shipped):

* a 3 x 5 (more MVs than CVs) with four empty cells and an integrating row
  (y2, a level: two integrating elements and one FOPTD), MV dither on every
  input -- with three setpoints for five inputs the dither is what makes
  the rows identifiable and the empty cells testable;
* the same with an explicit ``plant`` block that holds the mismatches and
  two interactions the model lacks (a FOPTD one in y1's empty G13, an
  integrating one in the level's empty G24);
* a 5 x 3 (more CVs than MVs) with four empty cells, no dither.

Specification (the parametric method): dK within 3 pp, dtau within 5 pp,
dD exact; an interaction's gain within 10 % and its delay exact.  The
classic method: gain ratio within 3 pp, delays exact.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import yaml
from simulated import diagnose_record

from pmr_ros.config import load_config
from pmr_ros.core.results.codec import diagnosis_from_json, diagnosis_to_json
from pmr_ros.core.sim.batch import simulate_many
from pmr_ros.core.sim.closed_loop import simulate

SEEDS = (1, 2, 3)

THREE_BY_FIVE = {
    "name": "three_by_five",
    "sample_time": 1.0,
    "output_names": ["y1", "level", "y3"],
    "input_names": ["u1", "u2", "u3", "u4", "u5"],
    # row-major; the level (row 2) integrates u1 and u3 [per minute] and follows u5 with a lag
    "element_type": [
        *("foptd", "foptd", "none", "foptd", "none"),
        *("integrating", "none", "integrating", "none", "foptd"),
        *("none", "foptd", "foptd", "none", "foptd"),
    ],
    "gain": [2.0, -1.5, 0.0, 1.2, 0.0, 0.05, 0.0, -0.04, 0.0, 1.0, 0.0, 1.8, -1.4, 0.0, 1.6],
    "time_constant": [10.0, 12.0, 0.0, 14.0, 0.0, 0.0, 0.0, 0.0, 0.0, 11.0, 0.0, 9.0, 13.0, 0.0, 10.0],
    "delay": [2.0, 1.0, 0.0, 3.0, 0.0, 1.0, 0.0, 2.0, 0.0, 1.0, 0.0, 2.0, 1.0, 0.0, 3.0],
}
MISMATCH_3X5 = {
    "gain_pct": [10.0, 0, 0, -12.0, 0, 15.0, 0, 0, 0, 0, 0, 0, 12.0, 0, -10.0],
    "time_constant_pct": [0.0, 12.0, 0, 0, 0, 0, 0, 0, 0, -12.0, 0, 10.0, 0, 0, 0],
    "delay_samples": [0, 0, 0, 1, 0, 0, 0, 2, 0, 0, 0, 1, 0, 0, 0],
}
INTERACTIONS = {(0, 2): ("foptd", 0.8, 8.0, 3), (1, 3): ("integrating", 0.03, 0.0, 2)}
"""Empty cells where the plant of the interaction test has an element: kind, gain, tau, delay [samples]."""

FIVE_BY_THREE = {
    "name": "five_by_three",
    "sample_time": 1.0,
    "output_names": ["y1", "y2", "y3", "y4", "y5"],
    "input_names": ["u1", "u2", "u3"],
    "element_type": [
        *("foptd", "foptd", "none"),
        *("foptd", "none", "foptd"),
        *("none", "foptd", "foptd"),
        *("foptd", "foptd", "none"),
        *("none", "foptd", "foptd"),
    ],
    "gain": [2.0, -1.2, 0.0, 1.5, 0.0, 1.0, 0.0, 1.8, -1.1, 1.2, 0.9, 0.0, 0.0, -1.0, 1.6],
    "time_constant": [10.0, 12.0, 0.0, 14.0, 0.0, 11.0, 0.0, 9.0, 12.0, 13.0, 11.0, 0.0, 0.0, 10.0, 12.0],
    "delay": [2.0, 1.0, 0.0, 3.0, 0.0, 1.0, 0.0, 2.0, 1.0, 1.0, 2.0, 0.0, 0.0, 1.0, 3.0],
}
MISMATCH_5X3 = {
    "gain_pct": [10.0, 0, 0, 0, 0, -12.0, 0, 0, 0, 0, 15.0, 0, 0, 0, 0],
    "time_constant_pct": [0.0, 12.0, 0, 0, 0, 0, 0, 0, -12.0, 0, 0, 0, 0, 10.0, 0],
    "delay_samples": [0, 0, 0, 1, 0, 0, 0, 2, 0, 0, 0, 0, 0, 0, 1],
}


def params_file(tmp_path: Path, tree: dict, name: str = "system.yaml") -> Path:
    """A ROS 2 params file holding ``tree``."""
    path = tmp_path / name
    path.write_text(yaml.safe_dump({"/**": {"ros__parameters": tree}}))
    return path


def plant_block(system: dict, mismatch: dict, interactions: dict) -> dict:
    """The true plant: the model with ``mismatch`` applied, plus elements in some empty cells."""
    kinds = list(system["element_type"])
    gain = [g * (1 + p / 100) for g, p in zip(system["gain"], mismatch["gain_pct"], strict=True)]
    tau = [t * (1 + p / 100) for t, p in zip(system["time_constant"], mismatch["time_constant_pct"], strict=True)]
    delay = [d + s for d, s in zip(system["delay"], mismatch["delay_samples"], strict=True)]
    n_in = len(system["input_names"])
    for (i, k), (kind, g, t, d) in interactions.items():
        j = i * n_in + k
        kinds[j], gain[j], tau[j], delay[j] = kind, g, t, float(d)
    return {"element_type": kinds, "gain": gain, "time_constant": tau, "delay": delay}


@pytest.fixture(scope="module")
def configs(tmp_path_factory):
    """The 3 x 5 (mismatch, and explicit plant with interactions) and the 5 x 3."""
    folder = tmp_path_factory.mktemp("industrial")
    dither = {"mv_dither_amplitude": 0.3}
    return {
        "3x5": load_config(
            params_file(folder, {"system": THREE_BY_FIVE, "mismatch": MISMATCH_3X5, "excitation": dither}, "a.yaml")
        ),
        "3x5 plant": load_config(
            params_file(
                folder,
                {
                    "system": THREE_BY_FIVE,
                    "plant": plant_block(THREE_BY_FIVE, MISMATCH_3X5, INTERACTIONS),
                    "excitation": dither,
                },
                "b.yaml",
            )
        ),
        "5x3": load_config(params_file(folder, {"system": FIVE_BY_THREE, "mismatch": MISMATCH_5X3}, "c.yaml")),
    }


class _Diagnoses:
    """Both methods' diagnoses of ``[label, scenario, seed, method]``, each system and scenario simulated on first use.

    One piece per system and scenario, so that the parallel test workers share the work out; each piece once per
    session (the ``shared`` fixture), whichever worker asks first.
    """

    def __init__(self, configs, shared) -> None:
        self.configs, self.shared = configs, shared

    def __getitem__(self, key):
        label, scenario, seed, method = key

        def piece():
            config = self.configs[label]
            records = simulate_many(config, [(scenario, s) for s in SEEDS])
            return {
                (s, m): diagnose_record(record, config, method=m, with_dither=True)
                for s, record in zip(SEEDS, records, strict=True)
                for m in ("classic", "parametric")
            }

        name = f"test_industrial_diagnosis_{label.replace(' ', '_')}_{scenario}_seeds_{'_'.join(map(str, SEEDS))}"
        return self.shared(name, piece)[seed, method]


@pytest.fixture(scope="module")
def diagnoses(configs, shared):
    """Both methods' diagnoses of every system and scenario, over :data:`SEEDS` (computed as the tests ask)."""
    return _Diagnoses(configs, shared)


def _truth(config, scenario: str):
    """Injected dK %, dtau %, dD per element (zero where the scenario injects none)."""
    mm = config.mismatch.for_scenario(scenario)
    return mm.gain_pct, mm.time_constant_pct, mm.delay_samples


def _assert_parametric_within_specification(diagnosis, truth) -> None:
    gain, tau, delay = truth
    for e in diagnosis:
        i, k, p = e.row, e.column, e.parametric
        if e.model.kind == "none":
            assert e.verdict == "ok" and p.unmodeled_verdict == "ok", (e.name, e.summary())
            continue
        injected = bool(gain[i, k] or tau[i, k] or delay[i, k])
        assert e.verdict == ("mismatch" if injected else "ok"), (e.name, e.summary(), e.all_reasons)
        assert abs(p.gain_mismatch_pct - gain[i, k]) <= 3.0, (e.name, e.summary())
        assert p.delay_mismatch_samples == delay[i, k], (e.name, e.summary())
        if e.model.kind == "integrating":
            assert p.tau_mismatch_pct is None and p.tau_verdict is None and p.tau_mismatch_pct_interval is None
        else:
            assert abs(p.tau_mismatch_pct - tau[i, k]) <= 5.0, (e.name, e.summary())


def _assert_classic_within_specification(diagnosis, truth) -> None:
    gain, tau, delay = truth
    for e in diagnosis:
        i, k, c = e.row, e.column, e.classic
        if e.model.kind == "none":
            assert c is None and e.verdict == "inconclusive" and "does not test empty cells" in e.reasons[0]
            continue
        assert abs(100 * (c.gain_ratio - 1) - gain[i, k]) <= 3.0, (e.name, c.summary())
        assert c.delay_mismatch_samples == delay[i, k], (e.name, c.summary())
        assert c.gain_mismatch == bool(gain[i, k]), (e.name, c.summary())
        assert c.delay_mismatch == bool(delay[i, k]), (e.name, c.summary())
        if e.model.kind == "integrating":
            assert c.tau_index is None and not c.tau_mismatch
        elif tau[i, k]:
            assert c.tau_mismatch and np.sign(c.tau_index) == np.sign(tau[i, k]), (e.name, c.summary())


@pytest.mark.parametrize("label", ["3x5", "5x3"])
@pytest.mark.parametrize("scenario", ["full", "none"])
def test_parametric_finds_every_injected_mismatch_and_nothing_else(configs, diagnoses, label, scenario):
    config = configs[label]
    for seed in SEEDS:
        diagnosis = diagnoses[label, scenario, seed, "parametric"]
        assert diagnosis.status == "ok"
        _assert_parametric_within_specification(diagnosis, _truth(config, scenario))


@pytest.mark.parametrize("label", ["3x5", "5x3"])
@pytest.mark.parametrize("scenario", ["full", "none"])
def test_classic_reads_every_modeled_element_within_specification(configs, diagnoses, label, scenario):
    config = configs[label]
    for seed in SEEDS:
        diagnosis = diagnoses[label, scenario, seed, "classic"]
        assert diagnosis.status == "ok"
        _assert_classic_within_specification(diagnosis, _truth(config, scenario))


def test_an_unmodeled_interaction_is_found_with_its_gain_and_delay(configs, diagnoses):
    config = configs["3x5 plant"]
    names = config.model.element_names()
    n_in = config.model.n_inputs
    for seed in SEEDS:
        diagnosis = diagnoses["3x5 plant", "full", seed, "parametric"]
        for (i, k), (kind, gain, _, delay) in INTERACTIONS.items():
            e = diagnosis.elements[names[i * n_in + k]]
            p = e.parametric
            assert e.model.kind == "none" and e.verdict == "mismatch" and p.mismatches == ("interaction",), kind
            assert p.unmodeled_gain == pytest.approx(gain, rel=0.10), (e.name, e.summary())
            assert p.unmodeled_delay_samples == delay, (e.name, e.summary())
            low, high = p.unmodeled_gain_interval
            assert low < p.unmodeled_gain < high and low > 0
            assert p.delay_confidence is not None and p.delay_confidence >= 0.95  # present: its delay profiled
        # every other element as without the interactions: the modeled ones within specification, the
        # remaining empty cells ok
        rest = [e for e in diagnosis if (e.row, e.column) not in INTERACTIONS]
        truth = _truth(configs["3x5"], "full")
        unprofiled = 0
        for e in rest:
            if e.model.kind == "none":
                assert e.verdict == "ok", (e.name, e.summary())
                unprofiled += e.parametric.delay_confidence is None  # absent: its flat delay not profiled
            else:
                assert abs(e.parametric.gain_mismatch_pct - truth[0][e.row, e.column]) <= 3.0, (e.name, e.summary())
                assert e.parametric.delay_mismatch_samples == truth[2][e.row, e.column], e.name
        assert unprofiled >= 1


def test_the_integrating_row_recovers_the_injected_ratio_exactly_without_noise(tmp_path):
    """Differencing the level's row is unbiased: noise-free, the fit gives the injected K/Khat and dD.

    Exact up to the leakage of the Welch window, which shrinks with the segment: 1024 samples keep
    every element within 0.05 pp (the automatic 512 leaves up to 0.19 pp on the FOPTD elements).
    Eight instruments need 16 segments of 1024: 10,240 samples.
    """
    tree = {
        "system": THREE_BY_FIVE,
        "mismatch": MISMATCH_3X5,
        "excitation": {"mv_dither_amplitude": 0.3},
        "noise": {"std": 0.0},
        "parametric": {"segment_length": 1024},
    }
    config = load_config(params_file(tmp_path, tree))
    record = simulate(config, samples=10240)
    diagnosis = diagnose_record(record, config, method="parametric", with_dither=True)
    gain, tau, delay = _truth(config, "full")
    for e in diagnosis:
        if e.model.kind == "none":  # nothing there: a gain that carries nothing of the row's output
            assert abs(e.parametric.quality["unmodeled_share_pct"]) < 0.1 and e.verdict == "ok", e.name
            continue
        p = e.parametric
        assert p.gain_mismatch_pct == pytest.approx(gain[e.row, e.column], abs=0.05), e.name
        assert p.delay_mismatch_samples == delay[e.row, e.column], e.name
        if e.model.kind == "foptd":
            assert p.tau_mismatch_pct == pytest.approx(tau[e.row, e.column], abs=0.05), e.name
    level = [e for e in diagnosis if e.row == 1 and e.model.kind == "integrating"]
    assert len(level) == 2 and all(e.verdict == "mismatch" for e in level)


# -- what the data cannot tell -------------------------------------------------------------------


@pytest.mark.parametrize(
    "label,overrides",
    [
        ("search range 1, true dD +2", {"pmr": {"max_delay_samples": 1}}),
        ("search range 10, true dD +20", {"mismatch": {"delay_samples": [0, 1, 20, 0]}}),
    ],
)
def test_a_delay_beyond_the_search_range_is_inconclusive_not_confidently_wrong(label, overrides):
    """Wood-Berry's G21 delay lies beyond the search: both methods say so instead of bending gain and tau."""
    config = load_config(overrides=overrides)
    record = simulate(config, seed=1)
    for method in ("parametric", "classic"):
        diagnosis = diagnose_record(record, config, method=method)
        g21 = diagnosis.elements["G21"]
        assert g21.verdict == "inconclusive", (label, method, g21.summary())
        assert any("pmr.max_delay_samples" in reason for reason in g21.all_reasons), (label, method, g21.all_reasons)
        if method == "parametric":
            p = g21.parametric
            assert p.tau_verdict == "inconclusive" and p.gain_verdict == "inconclusive", p.summary()
            # the row's other element shares the misfit: it is not given a confident verdict either
            assert diagnosis.elements["G22"].verdict == "inconclusive", diagnosis.elements["G22"].summary()
        # the first row's delays are within the range: still found
        assert diagnosis.elements["G11"].verdict == "mismatch", (label, method)


def test_a_row_without_enough_instruments_names_the_missing_excitation(tmp_path):
    """Three setpoints, five inputs, no dither: every row but one is diagnosed, the empty cells untested.

    y1's three modeled elements are found; a fourth modeled element in y3 makes that row unidentifiable,
    and the reason says which dither would help.
    """
    system = dict(THREE_BY_FIVE)
    kinds = list(system["element_type"])
    gains = list(system["gain"])
    taus = list(system["time_constant"])
    kinds[10], gains[10], taus[10] = "foptd", 0.9, 11.0  # G31 modeled too: y3 has four modeled inputs
    system.update(element_type=kinds, gain=gains, time_constant=taus)
    config = load_config(params_file(tmp_path, {"system": system, "mismatch": MISMATCH_3X5}))
    record = simulate(config, samples=8192)
    for method in ("parametric", "classic"):
        diagnosis = diagnose_record(record, config, method=method)
        for e in diagnosis:
            if e.row == 2 and not (method == "classic" and e.model.kind == "none"):
                assert e.verdict == "inconclusive" and (e.result is None or e.result.gain_mismatch_pct is None), e.name
                assert any("row y3 not identifiable: 4 modeled inputs but 3 instruments" in r for r in e.all_reasons)
                assert any(
                    "add MV dither (excitation.mv_dither_amplitude) on at least 1 of" in r for r in e.all_reasons
                )
            elif e.model.kind == "none":
                assert e.verdict == "inconclusive", (method, e.name)
        if method == "parametric":
            g13 = diagnosis.elements["G13"]
            assert any("not tested: row y1 has 3 instruments for 5 inputs" in r for r in g13.all_reasons)
            g11 = diagnosis.elements["G11"].parametric
            assert g11.verdict == "mismatch" and abs(g11.gain_mismatch_pct - 10.0) <= 3.0
            assert any("assumes no unmodeled interaction" in w for w in g11.warnings)


def test_an_industrial_diagnosis_round_trips_through_diagnostics_and_json(configs, diagnoses):
    """Integrating elements, interactions and untested cells keep every field on /diagnostics, estimates and JSON."""
    import json

    import rclpy  # noqa: F401  # the ROS 2 wheels are part of the set-up

    from pmr_ros.contract.layout import diagnosis_from_array, read_estimates
    from pmr_ros.core.results import compare_diagnoses
    from pmr_ros.ros import convert

    diagnosis = diagnoses["3x5 plant", "full", 1, "parametric"]
    statuses = convert.diagnosis_statuses(
        diagnosis, prefix="pmr/x", hardware_id="x", window={"window_samples": diagnosis.samples}
    )
    back, _ = diagnosis_from_array(convert.diagnostic_array(statuses, 0.0), prefix="pmr/x")
    assert back == diagnosis
    assert compare_diagnoses(diagnosis_from_json(json.loads(json.dumps(diagnosis_to_json(diagnosis)))), diagnosis) == []
    estimates = read_estimates(convert.estimates_message(diagnosis, 0.0, "x"))
    assert estimates["G13"]["parametric.unmodeled_gain"] == pytest.approx(
        diagnosis.elements["G13"].parametric.unmodeled_gain
    )
    assert np.isnan(estimates["G21"]["parametric.tau_mismatch_pct"])  # an integrating element has no time constant
    levels = {s.name.rsplit("/", 1)[1]: s.level for s in statuses}
    assert levels["G13"] == levels["G21"] == statuses[0].WARN  # one property off: the interaction; the gain
