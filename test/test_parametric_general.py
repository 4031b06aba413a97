"""The parametric PMR of elements of any type (issue 23): tf and step-response models, a plant of another structure.

The records are step tests: every MV moved by random steps with its
controller off (``manual``), the outputs the plant's response plus white
noise, simulated with :func:`~pmr_ros.core.sim.realize.element_outputs`.
"""

from __future__ import annotations

from functools import cache

import numpy as np
import pytest
from scipy.optimize import least_squares
from scipy.signal import cont2discrete, dfreqresp

from pmr_ros.config import load_config
from pmr_ros.core.pmr.curves import ElementCurves, fitted_ratio, pmr_curves
from pmr_ros.core.pmr.identifiable import RowLayout
from pmr_ros.core.pmr.implicit import instrument_factor
from pmr_ros.core.pmr.parametric import diagnose_parametric
from pmr_ros.core.pmr.parametric.fit import RowFit
from pmr_ros.core.pmr.parametric.method import _fit as method_fit
from pmr_ros.core.pmr.parametric.parameterization import column_models
from pmr_ros.core.pmr.parametric.ratio import ColumnModel, ratio_shape
from pmr_ros.core.pmr.parametric.scaled import ScaledShape
from pmr_ros.core.pmr.parametric.verdicts import SHAPE_REASON, element_result
from pmr_ros.core.pmr.spectra import record_spectra
from pmr_ros.core.pmr.timescale import equivalent_time_constant, slowest_time_constant
from pmr_ros.core.records import Record
from pmr_ros.core.results import Diagnosis
from pmr_ros.core.sim.lti import Foptd
from pmr_ros.core.sim.model import TransferMatrix
from pmr_ros.core.sim.rational import transfer_function
from pmr_ros.core.sim.realize import element_outputs
from pmr_ros.core.sim.step_curve import as_step_response

CONFIG = load_config()
SAMPLES = 16384
NOISE = 0.1
STEP_COEFFICIENTS = 120
"""Of the step-response model converted from the tf one: every element settled to 1e-4 by then."""

CHANGES = {
    # element: (gain ratio rho, time scale alpha, delay change dD)
    (0, 0): (1.20, 1.25, 0),
    (0, 1): (1.0, 1.0, 0),
    (1, 0): (0.85, 1.0, 2),
    (1, 1): (1.0, 0.8, -1),
}


def _tf(num: str, den: str, delay: int) -> object:
    return transfer_function(num, den, delay_samples=delay, sample_time=1.0)


def _tf_model() -> TransferMatrix:
    """Second order (10 and 3), lead-lag, inverse response (a zero at s = +1/3), underdamped second order."""
    rows = [
        [_tf("1.5", "30, 13, 1", 2), _tf("3.2, 0.8", "12, 1", 3)],
        [_tf("-3.6, 1.2", "32, 12, 1", 1), _tf("1", "25, 4, 1", 4)],
    ]
    return TransferMatrix.of_elements(rows, sample_time=1.0)


def _changed(model: TransferMatrix, changes: dict) -> TransferMatrix:
    rows = [
        [
            model.element(i, k).scaled(
                gain_ratio=changes.get((i, k), (1.0, 1.0, 0))[0],
                time_scale=changes.get((i, k), (1.0, 1.0, 0))[1],
                delay_change=changes.get((i, k), (1.0, 1.0, 0))[2],
            )
            for k in range(model.n_inputs)
        ]
        for i in range(model.n_outputs)
    ]
    return TransferMatrix.of_elements(rows, sample_time=model.sample_time)


def _step_test(plant: TransferMatrix, *, seed: int, samples: int = SAMPLES, noise: float = NOISE) -> Record:
    """Every MV in manual, moved by +-1 steps held 15 samples; white output noise of ``noise``."""
    rng = np.random.default_rng(seed)
    moves = rng.choice([-1.0, 1.0], size=(samples // 15 + 1, plant.n_inputs))
    u = np.repeat(moves, 15, axis=0)[:samples]
    y = element_outputs(plant.element_rows(), u).sum(axis=2)
    y = y + noise * rng.standard_normal(y.shape)
    return Record(np.zeros_like(y), u, y, manual=np.ones(u.shape, dtype=bool))


def _diagnose(record: Record, model: TransferMatrix) -> Diagnosis:
    return diagnose_parametric([record], model=model, classic=CONFIG.pmr, settings=CONFIG.parametric)


@cache
def _tf_case() -> tuple[Record, Diagnosis]:
    model = _tf_model()
    record = _step_test(_changed(model, CHANGES), seed=1)
    return record, _diagnose(record, model)


# -- the shape of a scaled element ---------------------------------------------------------------------


def test_a_first_order_tf_scales_exactly_as_the_foptd_ratio():
    shape = ScaledShape(_tf("2", "10, 1", 3))
    omega = np.linspace(0.0, np.pi, 40)
    z_inv = np.exp(-1j * omega)
    s = np.array([-0.4, 0.0, 0.3])
    values, derivative = shape.shapes(z_inv, s)
    foptd = ColumnModel("ratio", np.exp(-1 / 10.0), 10.0, (-3.0, 3.0), (-3, 3), False)
    expected, expected_derivative = foptd.shapes(z_inv, s)
    np.testing.assert_allclose(values, expected, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(derivative, expected_derivative, rtol=1e-6, atol=1e-9)
    np.testing.assert_allclose(values[2], ratio_shape(z_inv, np.exp(-0.1), np.exp(-1 / (10 * np.exp(0.3))), 0))


@pytest.mark.filterwarnings("ignore::scipy.signal.BadCoefficients")  # cont2discrete's numerator leads with ~1e-17
def test_the_shape_is_the_sampled_element_with_scaled_coefficients_over_the_model():
    """Checked against scipy's own ZOH sampling of ``num(alpha s) / den(alpha s)``."""
    element, alpha = _tf("-3.6, 1.2", "32, 12, 1", 1), 1.3
    omega = np.linspace(0.01, 3.0, 30)

    def sampled(num, den):
        b, a, _ = cont2discrete((num, den), 1.0, method="zoh")
        return dfreqresp((b.ravel(), a, 1.0), w=omega)[1]

    truth = sampled([-3.6 * alpha, 1.2], [32 * alpha**2, 12 * alpha, 1]) / sampled([-3.6, 1.2], [32, 12, 1])
    np.testing.assert_allclose(ScaledShape(element).ratio(omega, alpha), truth, rtol=1e-9)


def test_an_integrating_elements_scale_keeps_its_ramp_rate():
    lagged = ScaledShape(_tf("0.5", "10, 1, 0", 2))
    low = lagged.ratio(np.array([0.0, 1e-4]), 1.6)
    np.testing.assert_allclose(low, 1.0, atol=1e-3)
    assert lagged.has_dynamics
    assert not ScaledShape(_tf("0.5", "1, 0", 2)).has_dynamics
    model = TransferMatrix.of_elements([[_tf("0.5", "1, 0", 2), _tf("0.5", "10, 1, 0", 2)]], sample_time=1.0)
    kinds = [c.kind for c in column_models(model, RowLayout(0, np.arange(2)), max_delay_samples=4)]
    assert kinds == ["delay", "scaled"]


def test_a_scaled_columns_time_domain_response_is_its_coefficient():
    element, s, delay = _tf("3.2, 0.8", "12, 1", 3), 0.2, 2
    model = TransferMatrix.of_elements([[element]], sample_time=1.0)
    column = column_models(model, RowLayout(0, np.array([0])), max_delay_samples=4)[0]
    n = 4096
    impulse = np.zeros(n)
    impulse[1] = 1.0  # after a sample at rest: the response starts at steady state for u[0]
    response = column.response(impulse, lin=1.3, s=s, delay=delay)
    omega = 2 * np.pi * np.fft.rfftfreq(n)
    coefficient = 1.3 * column.shapes(np.exp(-1j * omega), np.array([s]))[0][0] * np.exp(-1j * omega * (delay + 1))
    np.testing.assert_allclose(np.fft.rfft(response), coefficient * element.frequency_response(omega), atol=1e-9)


def test_equivalent_time_constants_size_the_segments_by_the_slowest_element():
    assert equivalent_time_constant(Foptd(1.0, 7.0, 2, 1.0)) == 7.0
    curve = as_step_response(_tf("1", "10, 1", 3), 150)
    assert equivalent_time_constant(curve) == pytest.approx(10.0, rel=0.01)
    # a lead-lag settles with its lag: |a/b - 1| exp(-t/b) = exp(-3) at t = b (3 + ln 1.5)
    assert equivalent_time_constant(_tf("18, 1", "12, 1", 0)) == pytest.approx(12 * (3 + np.log(0.5)) / 3, rel=0.01)
    assert slowest_time_constant(_tf_model()) == pytest.approx(
        max(equivalent_time_constant(e) for row in _tf_model().element_rows() for e in row)
    )


# -- known truth -------------------------------------------------------------------------------------


def test_gain_dynamics_and_delay_changes_of_tf_elements_found_within_specification():
    """Second order, lead-lag, inverse response, underdamped: dK 3 pp, dalpha 5 pp, dD exact; the rest ok."""
    _, diagnosis = _tf_case()
    assert diagnosis.status == "ok", diagnosis.reason
    for (i, k), (rho, alpha, dD) in CHANGES.items():
        element = diagnosis.elements[f"G{i + 1}{k + 1}"]
        p = element.parametric
        assert element.model.kind == "tf"
        assert abs(p.gain_mismatch_pct - 100 * (rho - 1)) <= 3.0, element.name
        assert abs(p.tau_mismatch_pct - 100 * (alpha - 1)) <= 5.0, element.name
        assert p.delay_mismatch_samples == dD, element.name
        expected = tuple("ok" if no_change else "mismatch" for no_change in (rho == 1.0, alpha == 1.0, dD == 0))
        assert (p.gain_verdict, p.tau_verdict, p.delay_verdict) == expected, element.name
        assert not p.reasons, element.name


def test_a_step_response_model_converted_from_the_tf_model_gives_the_same_diagnosis():
    record, tf_diagnosis = _tf_case()
    tf_model = _tf_model()
    rows = [[as_step_response(e, STEP_COEFFICIENTS) for e in row] for row in tf_model.element_rows()]
    diagnosis = _diagnose(record, TransferMatrix.of_elements(rows, sample_time=1.0))
    assert diagnosis.status == "ok", diagnosis.reason
    for name, element in diagnosis.elements.items():
        p, q = element.parametric, tf_diagnosis.elements[name].parametric
        assert element.model.kind == "step_response"
        assert p.verdicts == q.verdicts, name
        # the curve is the tf's sampled response to 1e-4: the scaled curve is a cubic spline of it
        assert p.gain_mismatch_pct == pytest.approx(q.gain_mismatch_pct, abs=0.2), name
        assert p.tau_mismatch_pct == pytest.approx(q.tau_mismatch_pct, abs=0.5), name
        assert p.delay_mismatch_samples == q.delay_mismatch_samples, name


def test_first_order_tf_elements_give_the_foptd_numbers():
    """The general path (a scaled element) fits a row as the FOPTD one (its closed form) does, on the same spectra."""
    foptd = TransferMatrix([[2.0, -1.0], [1.5, 0.8]], [[10.0, 16.0], [8.0, 12.0]], [[2.0, 1.0], [3.0, 2.0]], 1.0)
    rows = [
        [_tf(f"{foptd.gain[i, k]}", f"{foptd.time_constant[i, k]}, 1", int(foptd.delay[i, k])) for k in range(2)]
        for i in range(2)
    ]
    general = TransferMatrix.of_elements(rows, sample_time=1.0)
    record = _step_test(foptd.with_mismatch(CONFIG.mismatch), seed=3, samples=8192, noise=0.3)
    welch = CONFIG.parametric.welch(foptd, record.samples, CONFIG.pmr)
    spectra = record_spectra([record], foptd, welch)
    factor = instrument_factor(spectra.rr)
    parts = {"spectra": spectra, "factor": factor, "classic": CONFIG.pmr, "settings": CONFIG.parametric}
    for i in range(2):
        a = method_fit(i, spectra.row(i), model=foptd, **parts).fit
        b = method_fit(i, spectra.row(i), model=general, **parts).fit
        assert [c.kind for c in b.columns] == ["scaled", "scaled"]
        np.testing.assert_array_equal(b.delays, a.delays)
        np.testing.assert_allclose(b.lin, a.lin, atol=1e-6)
        np.testing.assert_allclose(b.s, a.s, atol=1e-6)
        np.testing.assert_allclose(b.sd_lin, a.sd_lin, rtol=1e-4)
        np.testing.assert_allclose(b.sd_s, a.sd_s, rtol=1e-4)
        np.testing.assert_allclose(b.lack_of_fit, a.lack_of_fit, rtol=1e-6)


def test_curves_show_the_plant_against_the_best_scaled_model():
    record, diagnosis = _tf_case()

    class Config:
        model, pmr, parametric = _tf_model(), CONFIG.pmr, CONFIG.parametric

    curves = pmr_curves([record], diagnosis, Config())
    plant = _changed(_tf_model(), CHANGES)
    for name in ("G11", "G21"):
        i, k = int(name[1]) - 1, int(name[2]) - 1
        curve: ElementCurves = curves[name]
        band = curve.band & (curve.omega > 0)
        truth = plant.element(i, k).frequency_response(curve.omega)
        # the best scaled model is the plant here (the changes are scalings), up to the fit's error
        np.testing.assert_allclose(curve.plant_fitted[band], truth[band], rtol=0.03, atol=0.02 * np.abs(truth).max())
        inside = np.abs(curve.plant_estimate - truth) <= curve.radius * np.abs(curve.model_response)
        assert inside[band].mean() >= 0.8, name
    p = diagnosis.elements["G11"]
    direct = fitted_ratio(p, curves["G11"].omega, 1.0, model_element=_tf_model().element(0, 0))
    np.testing.assert_allclose(direct, curves["G11"].fitted)


# -- a plant of another structure than its model --------------------------------------------------------------


def _second_order_plant() -> TransferMatrix:
    """Every element second order with time constants 5:1."""
    cells = [[(2.0, 10.0, 2), (-1.0, 15.0, 1)], [(1.5, 8.0, 3), (0.8, 12.0, 2)]]
    rows = [[_tf(f"{g}", f"{t * t / 5}, {1.2 * t}, 1", d) for g, t, d in row] for row in cells]
    return TransferMatrix.of_elements(rows, sample_time=1.0)


def _step_fit(element, n: int = 150) -> Foptd:
    """The FOPTD an engineer's step test gives: least squares on the step response, whole-sample dead time."""
    target = element.step_response(n)
    fits = []
    for delay in range(element.delay_samples + 6):
        result = least_squares(
            lambda p, d=delay: Foptd(p[0], p[1], d, 1.0).step_response(n) - target,
            [target[-1], 5.0],
            bounds=([-np.inf, 0.1], [np.inf, 1e3]),
        )
        fits.append((result.cost, Foptd(float(result.x[0]), float(result.x[1]), delay, 1.0)))
    return min(fits, key=lambda f: f[0])[1]


@cache
def _foptd_fit_model() -> TransferMatrix:
    plant = _second_order_plant()
    return TransferMatrix.of_elements([[_step_fit(e) for e in row] for row in plant.element_rows()], sample_time=1.0)


@pytest.mark.parametrize(("seed", "samples", "noise"), [(1, SAMPLES, 0.1), (4, SAMPLES, 0.1), (3, 4096, 0.3)])
def test_a_best_foptd_model_of_a_second_order_plant_has_no_confident_mismatch(seed, samples, noise):
    """At high SNR the shape is seen (inconclusive, named); at low SNR it is within noise: no mismatch either way."""
    model = _foptd_fit_model()
    np.testing.assert_allclose(model.gain, _second_order_plant().gain, rtol=0.01)
    diagnosis = _diagnose(_step_test(_second_order_plant(), seed=seed, samples=samples, noise=noise), model)
    assert diagnosis.status == "ok", diagnosis.reason
    for name, element in diagnosis.elements.items():
        assert element.parametric.mismatches == (), (name, element.parametric.summary())
    if noise == NOISE:
        shaped = [e for e in diagnosis.elements.values() if any(SHAPE_REASON in r for r in e.parametric.reasons)]
        assert len(shaped) >= 3
        assert all(e.parametric.tau_verdict == e.parametric.delay_verdict == "inconclusive" for e in shaped)


@pytest.mark.parametrize(("seed", "samples", "noise"), [(1, SAMPLES, 0.1), (3, 4096, 0.3)])
def test_a_real_gain_change_is_still_found_under_the_structural_mismatch(seed, samples, noise):
    plant = _changed(_second_order_plant(), {(0, 1): (1.15, 1.0, 0)})
    diagnosis = _diagnose(_step_test(plant, seed=seed, samples=samples, noise=noise), _foptd_fit_model())
    changed = diagnosis.elements["G12"].parametric
    assert changed.gain_verdict == "mismatch", changed.summary()
    low, high = changed.gain_mismatch_pct_interval
    assert low <= 15.0 <= high
    for name, element in diagnosis.elements.items():
        if name != "G12":
            assert element.parametric.mismatches == (), (name, element.parametric.summary())


# -- the gain under a lack of fit -------------------------------------------------------------------------


def _misfit(*, lin: float, steady: float | None, lack: float = 40.0, chi_square: float = 100.0) -> RowFit:
    column = ColumnModel("ratio", np.exp(-0.1), 10.0, (-3.0, 3.0), (-2, 6), True)
    return RowFit(
        lin=np.array([lin]),
        s=np.array([0.1]),
        delays=np.array([1]),
        sd_lin=np.array([0.005]),
        sd_s=np.array([0.01]),
        chi_square=chi_square,
        dof=100,
        delay_profile=({1: 0.0, 2: 50.0, 0: 50.0},),
        lack_of_fit=np.array([lack]),
        columns=(column,),
        steady_gain=None if steady is None else np.array([steady]),
        steady_gain_sd=None if steady is None else np.array([0.01]),
    )


@pytest.mark.parametrize(
    ("lin", "steady", "lack", "chi_square", "gain_verdict", "misfit"),
    [
        (1.15, 1.14, 40.0, 100.0, "mismatch", True),  # fit and steady state agree beyond the tolerance
        (1.15, 1.00, 40.0, 100.0, "inconclusive", True),  # they disagree: the hull straddles the tolerance
        (1.00, 1.01, 40.0, 100.0, "ok", True),
        (1.15, None, 40.0, 100.0, "inconclusive", True),  # no steady-state reading: nothing to check the gain by
        (1.15, 1.00, 1.0, 100.0, "mismatch", False),  # the fit follows the data: its own interval decides
        # the row beyond noise (z = 0.6 / sqrt(2 / 100) = 4.2 > 2.5) and the element above its noise
        (1.15, 1.00, 1.8, 160.0, "inconclusive", True),
        (1.15, 1.00, 1.8, 130.0, "mismatch", False),  # z = 2.1: within noise
        (1.15, 1.00, 0.9, 160.0, "mismatch", False),  # the element itself follows the data
    ],
)
def test_under_a_lack_of_fit_only_the_gain_is_judged_on_the_hull_with_the_steady_state(
    lin, steady, lack, chi_square, gain_verdict, misfit
):
    fit = _misfit(lin=lin, steady=steady, lack=lack, chi_square=chi_square)
    assert fit.misfit_z == pytest.approx((chi_square / 100 - 1) / np.sqrt(2 / 100))
    result = element_result(
        fit,
        0,
        settings=CONFIG.parametric,
        quality={},
        warnings=(),
        labels=[("G11", "u1")],
    )
    assert result.gain_verdict == gain_verdict
    assert (result.tau_verdict == result.delay_verdict == "inconclusive") == misfit
    assert any(r.startswith(SHAPE_REASON) for r in result.reasons) == misfit


_RAMPS = TransferMatrix.of_elements(
    [[_tf("0.05", "8, 1, 0", 2), _tf("1.5", "30, 13, 1", 1)], [_tf("-0.02", "1, 0", 3), _tf("1", "12, 1", 2)]],
    sample_time=1.0,
)


def test_integrating_tf_elements_keep_their_ramp_rate_as_the_gain_and_scale_the_rest():
    """``0.05/(s(8s+1))`` made 1.2x slower with rho 1.1: its ramp rate is rho/alpha; ``K/s`` has gain and delay only."""
    changes = {(0, 0): (1.1, 1.2, 0), (1, 0): (0.9, 1.0, 1)}
    diagnosis = _diagnose(_step_test(_changed(_RAMPS, changes), seed=1), _RAMPS)
    assert diagnosis.status == "ok", diagnosis.reason
    lagged, level = diagnosis.elements["G11"].parametric, diagnosis.elements["G21"].parametric
    assert lagged.gain_mismatch_pct == pytest.approx(100 * (1.1 / 1.2 - 1), abs=3.0)
    assert lagged.tau_mismatch_pct == pytest.approx(20.0, abs=5.0)
    assert (lagged.gain_verdict, lagged.tau_verdict, lagged.delay_verdict) == ("mismatch", "mismatch", "ok")
    assert level.gain_mismatch_pct == pytest.approx(-10.0, abs=3.0) and level.tau_mismatch_pct is None
    assert (level.gain_verdict, level.tau_verdict, level.delay_verdict) == ("mismatch", None, "mismatch")
    for name in ("G12", "G22"):
        assert diagnosis.elements[name].verdict == "ok", name
