"""Elements of any type in the loop: the plant, the MPC's prediction and stability, the batch, the corrected model.

Known truths: scipy.signal's own zero-order-hold sampling and simulation of
each transfer function, the step-response coefficients themselves (the DMC
dynamic matrix), the invariance of the loop's neutral modes, and the FOPTD
path's numbers for the same elements written as tf.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from numpy.testing import assert_allclose
from scipy.signal import cont2discrete, dlsim

from pmr_ros.config import load_config
from pmr_ros.core.loop.update import corrected_model
from pmr_ros.core.mpc.controller import LinearMpc
from pmr_ros.core.mpc.design import prediction_matrices, steady_state_gain
from pmr_ros.core.mpc.stability import closed_loop_matrix, loop_spectral_radius, neutral_modes
from pmr_ros.core.sim.augment import augmented_model, process_part
from pmr_ros.core.sim.batch import run_lockstep
from pmr_ros.core.sim.closed_loop import simulate
from pmr_ros.core.sim.model import Mismatch, TransferMatrix
from pmr_ros.core.sim.rational import transfer_function
from pmr_ros.core.sim.step_curve import as_step_response
from pmr_ros.core.sim.true_plant import FoptdPlant

TS = 1.0
ELEMENTS = (  # (numerator, denominator, delay): second order, inverse response, lead-lag, first order
    (("12.8", "40, 14, 1", 1), ("-0.5, 1", "20, 12, 1", 3)),
    (("5, 1", "10, 1", 2), ("-19.4", "14.4, 1", 3)),
)


def _tf_model(elements=ELEMENTS) -> TransferMatrix:
    rows = [
        [
            transfer_function(n, d, delay_samples=delay, sample_time=TS, name=f"G{i + 1}{k + 1}")
            for k, (n, d, delay) in enumerate(row)
        ]
        for i, row in enumerate(elements)
    ]
    return TransferMatrix.of_elements(rows, sample_time=TS, output_names=("y1", "y2"), input_names=("u1", "u2"))


def _step_model(model: TransferMatrix, n: int) -> TransferMatrix:
    rows = [[as_step_response(e, n, name="S") for e in row] for row in model.element_rows()]
    return TransferMatrix.of_elements(
        rows, sample_time=TS, output_names=model.output_names, input_names=model.input_names
    )


def _as_tf(m: TransferMatrix) -> TransferMatrix:
    """A FOPTD matrix with every element written as the tf ``K / (tau s + 1)``."""
    rows = [
        [
            transfer_function(
                repr(float(m.gain[i, k])),
                f"{float(m.time_constant[i, k])!r}, 1",
                delay_samples=int(m.delay_samples[i, k]),
                sample_time=m.sample_time,
            )
            for k in range(m.n_inputs)
        ]
        for i in range(m.n_outputs)
    ]
    return TransferMatrix.of_elements(
        rows, sample_time=m.sample_time, output_names=m.output_names, input_names=m.input_names
    )


def _scipy_output(num: str, den: str, delay: int, u: np.ndarray) -> np.ndarray:
    """y(k) of one tf element by scipy alone: ZOH sampled, the output read before the move of sample k acts."""
    b = [float(v) for v in num.split(",")]
    a = [float(v) for v in den.split(",")]
    num_d, den_d, _ = cont2discrete((b, a), TS, method="zoh")
    shifted = np.concatenate((np.zeros(delay), u))[: u.size]
    _, y = dlsim((np.atleast_2d(num_d)[0], den_d, TS), shifted)
    direct = b[0] / a[0] if len(b) == len(a) else 0.0  # a biproper element's feedthrough acts one sample later
    late = np.concatenate(([0.0], shifted[:-1]))
    return y[:, 0] - direct * shifted + direct * late


@pytest.mark.filterwarnings("ignore::scipy.signal.BadCoefficients")  # the sampled numerator's leading ~0
def test_the_plant_of_tf_elements_is_scipys_simulation_of_each():
    model = _tf_model()
    rng = np.random.default_rng(3)
    u = np.repeat(rng.standard_normal((40, 2)), 5, axis=0)  # held for 5 samples each
    plant = FoptdPlant(model, 0.0, seed=0)
    y = np.empty((u.shape[0], 2))
    for k in range(u.shape[0]):
        y[k] = plant.output()
        plant.advance(u[k])
    expected = sum(np.stack([_scipy_output(*ELEMENTS[i][k], u[:, k]) for i in range(2)], axis=1) for k in range(2))
    assert_allclose(y, expected, atol=1e-9)


def test_a_foptd_model_written_as_tf_gives_the_foptd_loop():
    config = load_config()  # Wood-Berry, FOPTD
    tf = _as_tf(config.model)
    assert tf.has_general  # realized by realize.realize, not the FOPTD realization
    plain = simulate(config, samples=600, seed=2, scenario="full")
    general = simulate(replace(config, model=tf), samples=600, seed=2, scenario="full")
    assert_allclose(general.u, plain.u, atol=1e-7)
    assert_allclose(general.y, plain.y, atol=1e-7)


def _loop_config(model: TransferMatrix, **changes):
    config = load_config()
    prbs = replace(config.prbs, clock_period=150, amplitude=np.ones(2))
    mpc = replace(config.mpc, u_min=np.full(2, -np.inf), u_max=np.full(2, np.inf), du_max=np.full(2, np.inf))
    mismatch = Mismatch(np.full((2, 2), 10.0), np.full((2, 2), -10.0), np.zeros((2, 2), dtype=int))
    base = replace(config, model=model, mpc=mpc, prbs=prbs, noise_std=np.zeros(2), mismatch=mismatch)
    return replace(base, **changes)


def _settled_error(record, hold: int = 150) -> np.ndarray:
    """|r - y| at the last sample of every setpoint hold after the first."""
    ends = np.arange(2 * hold - 1, record.r.shape[0], hold)
    return np.abs(record.r[ends] - record.y[ends])


def test_the_mpc_tracks_setpoints_on_tf_elements_in_the_batch_and_alone():
    config = _loop_config(_tf_model())
    done = run_lockstep(config, [("none", 1), ("full", 2)], samples=1500)
    for record in done.records:
        assert np.count_nonzero(np.diff(record.r, axis=0)) >= 4  # setpoints that move
        assert np.all(np.isfinite(record.y))
        assert np.max(_settled_error(record)) < 1e-3  # offset-free under a 10 % gain / -10 % dynamics mismatch
    alone = simulate(config, samples=1500, seed=2, scenario="full")
    assert_allclose(done.records[1].y, alone.y, atol=1e-9)
    assert_allclose(done.records[1].u, alone.u, atol=1e-9)


def test_a_step_response_model_drives_the_loop_as_its_tf_within_the_truncation():
    tf = _tf_model()
    steps = _step_model(tf, 400)  # every element settled to 1e-9 of its gain by then
    truncation = max(abs(e.steady_state_gain - e.step_response(400)[-1]) for row in tf.element_rows() for e in row)
    assert truncation < 1e-8
    config = _loop_config(
        tf,
        explicit_plant=tf.with_mismatch(Mismatch(np.full((2, 2), 10.0), np.zeros((2, 2)), np.zeros((2, 2), dtype=int))),
    )
    by_tf = simulate(config, samples=900, seed=1)
    by_steps = simulate(replace(config, model=steps), samples=900, seed=1)
    assert_allclose(by_steps.u, by_tf.u, atol=1e-5)
    assert_allclose(by_steps.y, by_tf.y, atol=1e-5)


def test_the_prediction_of_a_step_response_model_is_the_dmc_dynamic_matrix():
    steps = _step_model(_tf_model(), 60)
    _, psi, theta = prediction_matrices(steps.state_space(), prediction_horizon=30, control_horizon=4)
    curves = np.array([[e.step_response(30) for e in row] for row in steps.element_rows()])  # (2, 2, 30)
    for j in range(30):
        assert_allclose(theta[2 * j : 2 * j + 2, :2], curves[:, :, j], atol=1e-12)  # S_(j+1): the first move
        if j >= 1:
            assert_allclose(theta[2 * j : 2 * j + 2, 2:4], curves[:, :, j - 1], atol=1e-12)  # one sample later
    assert_allclose(psi.reshape(30, 2, 2), np.moveaxis(curves, 2, 0), atol=1e-12)


def test_steady_state_and_integrators_of_general_elements():
    level = transfer_function("0.2", "5, 1, 0", delay_samples=1, sample_time=TS, name="G11")  # 0.2 / (s (5 s + 1))
    heat = transfer_function("3, 1", "30, 11, 1", delay_samples=0, sample_time=TS, name="G21")
    rows = [
        [level, transfer_function("-0.1", "8, 1, 0", delay_samples=2, sample_time=TS)],
        [heat, as_step_response(heat, 200)],
    ]
    model = TransferMatrix.of_elements(rows, sample_time=TS)
    assert model.integrating.tolist() == [[True, True], [False, False]]
    assert_allclose(steady_state_gain(model), [[0.2 * TS, -0.1 * TS], [1.0, 1.0]], atol=1e-12)
    config = load_config()
    mpc = LinearMpc(model, replace(config.mpc, u_min=np.full(2, -np.inf), u_max=np.full(2, np.inf)))
    plant = model.with_mismatch(Mismatch(np.full((2, 2), 10.0), np.full((2, 2), 5.0), np.zeros((2, 2), dtype=int)))
    M, neutral = closed_loop_matrix(mpc, plant), neutral_modes(mpc, plant)
    # the model's two integrators (each offset by its step estimate) and the plant's pair in one row
    assert neutral.shape[1] == 3
    assert_allclose(M @ neutral, neutral, atol=1e-9)
    assert loop_spectral_radius(mpc, plant) < 1.0


def test_dvs_beside_general_elements_keep_them():
    model = _tf_model()
    dv = TransferMatrix([[0.5], [0.2]], [[4.0], [6.0]], [[1.0], [0.0]], TS, input_names=("feed",))
    whole = augmented_model(model, dv)
    assert whole.n_disturbances == 1 and whole.element_names()[-1] == "D21"
    assert whole.element(0, 1) == model.element(0, 1)
    assert process_part(whole).element_rows() == model.element_rows()


def test_a_corrected_tf_element_is_the_element_scaled_as_the_foptd_one_is_corrected():
    from pmr_ros.core.pmr.diagnosis import diagnose

    config = load_config()
    record = simulate(config, samples=4000, seed=1)
    diagnosis = diagnose(record.r, record.u, record.y, model=config.model, pmr=config.pmr, parametric=config.parametric)
    m = config.model
    tf = _as_tf(m)
    plain, general = corrected_model(m, diagnosis), corrected_model(tf, diagnosis)
    assert [c.name for c in general.changes] == [c.name for c in plain.changes] and plain.changes
    for i in range(2):
        for k in range(2):
            assert general.model.element_type[i, k] == "tf"
            assert_allclose(
                general.model.element(i, k).step_response(200),
                plain.model.element(i, k).step_response(200),
                rtol=1e-9,
                atol=1e-12,
            )
    change = general.changes[0]
    assert change.element is not None and "dynamics x" in change.note()


def test_the_adaptation_lines_show_a_time_constant_only_where_the_element_has_one():
    from pmr_ros.commands.adapt import adaptation_lines

    def model(kind, gain, tau):
        return {"kind": kind, "gain": gain, "time_constant": tau, "delay_samples": 1}

    report = {
        "adaptation": {
            "before": {"elements": {"G11": {"verdict": "mismatch"}, "G12": {"verdict": "mismatch"}}},
            "before_window": [0, 99],
            "changes": [
                {"element": "G11", "before": model("tf", 12.8, None), "after": model("tf", 15.4, None)},
                {"element": "G12", "before": model("foptd", 2.0, 5.0), "after": model("foptd", 2.2, 5.5)},
            ],
            "switch_sample": 120,
            "after_window": [150, 249],
            "tracking": {"before": {"ise_per_sample": 2.0}, "after": {"ise_per_sample": 1.0}, "ise_ratio": 0.5},
            "worse": False,
            "notes": [],
        }
    }
    lines = adaptation_lines(report)
    assert "  G11: K 12.8 -> 15.4, D 1 -> 1 samples" in lines
    assert "  G12: K 2 -> 2.2, tau 5.0 -> 5.5, D 1 -> 1 samples" in lines


def test_the_memory_check_counts_the_states_of_a_general_realization():
    from pmr_ros.core.sim.footprint import states

    for model in (_tf_model(), _step_model(_tf_model(), 90)):
        assert states(model) == model.state_space().A.shape[0]
    assert states(_step_model(_tf_model(), 90)) == 2 * 90  # a register of 90 taps per input, no own states


def test_a_switch_from_a_tf_model_to_its_corrected_curves_makes_no_bump():
    """At a steady state the controller switched to another model of any form makes no move (no bump)."""
    tf = _tf_model()
    truth = tf.with_mismatch(Mismatch(np.full((2, 2), 12.0), np.full((2, 2), 10.0), np.zeros((2, 2), dtype=int)))
    config = _loop_config(tf)
    controller, plant = LinearMpc(tf, config.mpc), FoptdPlant(truth, 0.0, seed=0)
    r = np.array([0.5, -0.3])
    u = np.zeros((1000, 2))
    for k in range(1000):
        if k == 800:
            controller = controller.switched(_step_model(truth, 400))  # the plant's own curves
        u[k] = controller.step(plant.measure(), r)
        plant.advance(u[k])
    assert_allclose(plant.output(), r, atol=1e-6)
    assert_allclose(u[800:], np.tile(u[799], (200, 1)), atol=1e-6)
    assert_allclose(controller.disturbance[0], 0.0, atol=1e-6)  # the curves explain the plant: no bias left
