"""The real controller of the control impact: ``controller.kind`` mpc, pi or external (issue 24, item 4).

The PI figures are checked against an independent simulation written here:
each FOPTD element discretized by hand (zero-order hold, whole-sample delay)
and the two velocity-form PI loops of Luyben's BLT tuning closed around it.
"""

from __future__ import annotations

import numpy as np
import pytest
from routine_cases import gain_only_fit

from pmr_ros.config import ConfigError, load_config
from pmr_ros.config.controller_block import FOREIGN, foreign_controller
from pmr_ros.core.loop.impact import control_impact, loop_figures
from pmr_ros.core.loop.pi_loops import PiLoop, PiTuning, simulate_pi
from pmr_ros.core.loop.update import corrected_model
from pmr_ros.core.results import Diagnosis, ElementDiagnosis, ParametricResult
from pmr_ros.core.sim.operation import setpoint_generator
from pmr_ros.service.closing import close_diagnosis

SAMPLES = 1500
LUYBEN = {"kind": "pi", "gain": [0.375, -0.075], "integral_time": [8.29, 23.6]}
"""Wood-Berry's BLT tuning (Luyben 1986): x_D by reflux, x_B by steam; Ti in minutes (the model's time unit)."""


def _fit(gain_pct: float) -> ParametricResult:
    return gain_only_fit(gain_pct, mismatch=bool(gain_pct), half_width_pct=2.0)


def _diagnosis(config, mismatched: str = "G11", gain_pct: float = 20.0) -> Diagnosis:
    """Verdicts with +20 % on one element's gain, the other three ok (as the diagnosis of such a plant reads)."""
    elements = {
        name: ElementDiagnosis(
            name, i, k, model, "parametric", parametric=_fit(gain_pct if name == mismatched else 0.0)
        )
        for name, (i, k, model) in config.model.element_models().items()
    }
    return Diagnosis("parametric", "ok", "", 8192, elements)


def _independent_pi(model, gain: np.ndarray, r: np.ndarray) -> float:
    """ISE of the diagonal PI loops on the FOPTD matrix ``gain``, tau, delay of ``model``: written from scratch."""
    ts = model.sample_time
    a = np.exp(-ts / model.time_constant)
    b = gain * (1.0 - a)
    d = np.rint(model.delay / ts).astype(int)
    n = r.shape[0]
    states = np.zeros((2, 2))
    u = np.zeros((n + 1, 2))
    kc, ti = np.array(LUYBEN["gain"]), np.array(LUYBEN["integral_time"])
    last = np.zeros(2)
    ise = 0.0
    for k in range(n):
        y = states.sum(axis=1)
        e = r[k] - y
        ise += float(np.sum(e**2))
        u[k] = u[k - 1] + kc * (e - last + ts / ti * e) if k else kc * (e + ts / ti * e)
        last = e
        delayed = np.array([[u[k - d[i, j], j] if k >= d[i, j] else 0.0 for j in range(2)] for i in range(2)])
        states = a * states + b * delayed
    return ise


@pytest.fixture(scope="module")
def pi_config():
    return load_config(overrides={"controller": LUYBEN})


def test_the_pi_impact_is_the_pi_loops_own_and_not_the_mpcs(pi_config):
    diagnosis = _diagnosis(pi_config)
    update = corrected_model(pi_config.model, diagnosis)
    np.testing.assert_allclose(update.model.gain[0, 0], 1.2 * pi_config.model.gain[0, 0], rtol=1e-12)
    with_pi = control_impact(diagnosis, loop=pi_config, update=update, samples=SAMPLES, controller=pi_config.controller)
    with_mpc = control_impact(diagnosis, loop=pi_config, update=update, samples=SAMPLES)
    r = setpoint_generator(pi_config.prbs, pi_config.run.seed).sequence(SAMPLES)
    truth = pi_config.model.gain * np.array([[1.2, 1.0], [1.0, 1.0]])
    expected = _independent_pi(pi_config.model, truth, r) / _independent_pi(pi_config.model, pi_config.model.gain, r)
    # the same loops, the same plant: equal but for the rounding of two realizations
    np.testing.assert_allclose(with_pi.elements["G11"].impact.ise_ratio, expected, rtol=1e-6)
    np.testing.assert_allclose(with_pi.impact.ise_ratio, expected, rtol=1e-6)
    assert abs(with_pi.impact.ise_ratio - 1.0) > 0.01  # a +20 % gain changes the PI loops' tracking
    assert abs(with_pi.impact.ise_ratio - with_mpc.impact.ise_ratio) > 0.02  # the MPC's figure is another loop's
    assert all(with_pi.elements[n].impact is None for n in ("G12", "G21", "G22"))


def test_pi_loops_follow_a_step_with_no_offset_and_respect_their_limits(pi_config):
    r = np.zeros((400, 2))
    r[:, 0] = 1.0
    y, u = simulate_pi(pi_config.controller.pi, pi_config.model, r)
    np.testing.assert_allclose(y[-1], [1.0, 0.0], atol=1e-3)  # integral action: no steady-state offset
    # steady state of the plant itself: y = K u
    np.testing.assert_allclose(pi_config.model.gain @ u[-1], y[-1], atol=1e-3)
    narrow = PiTuning(pi_config.controller.pi.loops, np.array([-0.05, -0.05]), np.array([0.05, 0.05]))
    _, held = simulate_pi(narrow, pi_config.model, r)
    assert np.max(np.abs(held)) <= 0.05 + 1e-12
    np.testing.assert_allclose(np.max(np.abs(held[:, 0])), 0.05)  # the limit is reached, not exceeded


def test_a_derivative_term_and_a_pairing_of_one_loop():
    config = load_config(
        overrides={
            "controller": {
                "kind": "pi",
                "pairing": ["", "reflux"],
                "gain": [0.0, 0.1],
                "integral_time": [1.0, 10.0],
                "derivative_time": [0.0, 2.0],
            }
        }
    )
    loop = config.controller.pi.loops
    assert loop == (PiLoop(1, 0, 0.1, 10.0, 2.0),)
    r = np.zeros((3, 2))
    r[:, 1] = 1.0
    _, u = simulate_pi(config.controller.pi, config.model, r)
    # from rest, e = 1 throughout (the plant has not answered yet):
    # du(0) = Kc (1 + Ts/Ti + Td/Ts), du(1) = Kc (Ts/Ti - Td/Ts), du(2) = Kc Ts/Ti
    du = 0.1 * np.array([3.1, 0.1 - 2.0, 0.1])
    np.testing.assert_allclose(u[:, 0], np.cumsum(du))
    np.testing.assert_array_equal(u[:, 1], 0.0)  # steam is in no loop


@pytest.mark.parametrize(
    ("controller", "message"),
    [
        ({"kind": "pi"}, "controller.gain: missing"),
        ({"kind": "pi", "gain": 1.0, "integral_time": [1.0, 0.0]}, r"controller.integral_time\[1\] = 0.0: must be > 0"),
        ({"kind": "pi", "gain": 1.0, "integral_time": 1.0, "pairing": ["reflux", "reflux"]}, "must be unique"),
        ({"kind": "pi", "gain": 1.0, "integral_time": 1.0, "pairing": ["feed", ""]}, "'feed' is not an input"),
        ({"kind": "pid"}, "controller.kind = 'pid': must be one of mpc, pi, external"),
    ],
)
def test_a_bad_controller_block_is_one_line(controller, message):
    with pytest.raises(ConfigError, match=message):
        load_config(overrides={"controller": controller})


def test_external_computes_no_impact_and_says_why_in_one_line(pi_config):
    diagnosis = _diagnosis(pi_config)
    external = load_config(overrides={"controller": {"kind": "external"}})
    closed = close_diagnosis(diagnosis, external)
    assert closed.diagnosis.impact is None and all(e.impact is None for e in closed.diagnosis)
    assert closed.impact_note.startswith("control impact not computed: controller.kind external")
    assert "\n" not in closed.impact_note
    assert closed.proposes  # the corrected model is still proposed


def test_data_from_elsewhere_default_to_external_unless_a_controller_is_given(pi_config):
    plain = load_config()
    assert plain.controller.kind == "mpc"
    foreign = foreign_controller(plain)
    assert foreign.controller.kind == "external" and foreign.controller.why_external == FOREIGN
    assert close_diagnosis(_diagnosis(plain), foreign).impact_note == FOREIGN
    assert foreign_controller(pi_config).controller.kind == "pi"  # a controller block is kept
    given_mpc = load_config(overrides={"controller": {"kind": "mpc"}})
    assert foreign_controller(given_mpc).controller.kind == "mpc"


def test_the_mpc_default_is_unchanged(pi_config):
    plain = load_config()
    base = loop_figures(plain, plain.model, samples=600)
    assert base == loop_figures(plain, plain.model, samples=600, controller=plain.controller)


def test_a_bag_without_a_recorded_configuration_is_another_controllers(tmp_path):
    from test_bag import REFERENCE, _write_small_bag

    from pmr_ros.bag.reader import open_bag
    from pmr_ros.service.bag_diagnosis import diagnose_bag

    params = REFERENCE.parent.parent / "config" / "wood_berry.yaml"
    _write_small_bag(tmp_path / "foreign", 40).close()
    assert diagnose_bag(open_bag(tmp_path / "foreign"), str(params)).config.controller.kind == "external"
    ours = diagnose_bag(open_bag(REFERENCE), str(params))  # recorded by the node set: its MPC
    assert ours.config.controller.kind == "mpc"
