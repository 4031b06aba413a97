"""A bumpless model switch of the MPC: the QP rebuilt, the input history and disturbance estimate carried over."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from pmr_ros.config import load_config
from pmr_ros.core.mpc.controller import LinearMpc
from pmr_ros.core.sim.true_plant import FoptdPlant


def _run(controller, plant, setpoints, *, switch_at=None, new_model=None):
    """Closed loop over ``setpoints``; the controller is replaced by ``switched(new_model)`` before ``switch_at``."""
    us, ys, steps = [], [], []
    for k, r in enumerate(setpoints):
        if k == switch_at:
            controller = controller.switched(new_model)
        y = plant.measure()
        u = controller.step(y, r)
        plant.advance(u)
        us.append(u)
        ys.append(y)
        steps.append(controller.disturbance[0])
    return np.array(us), np.array(ys), np.array(steps), controller


@pytest.fixture(scope="module")
def wood_berry():
    return load_config()


def test_switching_to_the_same_model_changes_nothing(wood_berry):
    rng = np.random.default_rng(3)
    r = np.repeat(rng.choice([-1.0, 1.0], size=(60, 2)), 16, axis=0)
    plant_model = wood_berry.plant("full")
    base, _, _, _ = _run(LinearMpc(wood_berry.model, wood_berry.mpc), FoptdPlant(plant_model, 0.0, 0), r)
    switched, _, _, _ = _run(
        LinearMpc(wood_berry.model, wood_berry.mpc),
        FoptdPlant(plant_model, 0.0, 0),
        r,
        switch_at=500,
        new_model=wood_berry.model,
    )
    # the history kept is 16 slowest time constants: the rebuilt state differs by exp(-16) of the inputs
    np.testing.assert_allclose(switched, base, atol=1e-6)


@pytest.mark.parametrize("kind", ["corrected", "wrong"])
def test_at_a_steady_state_a_new_model_makes_no_move(wood_berry, kind):
    """Offset-free at rest, the prediction stays y = r with any model: the optimal move is zero, no bump."""
    r = np.tile([0.5, -0.3], (900, 1))
    wrong = replace(wood_berry.model, gain=wood_berry.model.gain * 1.5)
    new = wood_berry.plant("full") if kind == "corrected" else wrong
    plant = FoptdPlant(wood_berry.plant("full"), 0.0, 0)
    u, y, _, _ = _run(LinearMpc(wood_berry.model, wood_berry.mpc), plant, r, switch_at=800, new_model=new)
    # the new state misses the inputs before the history kept: exp(-16) of them, which the loop then corrects
    np.testing.assert_allclose(y[790:], r[790:], atol=1e-6)
    np.testing.assert_allclose(u[800:], np.tile(u[799], (100, 1)), atol=1e-6)
    # a controller started cold on the new model would jump: the bump the switch avoids
    cold = LinearMpc(new, wood_berry.mpc)
    assert np.max(np.abs(cold.step(y[800], r[800]) - u[799])) > 0.1


def test_switching_to_the_true_plant_leaves_no_disturbance_to_estimate(wood_berry):
    rng = np.random.default_rng(4)
    r = np.repeat(rng.choice([-1.0, 1.0], size=(80, 2)), 16, axis=0)
    truth = wood_berry.plant("full")
    controller = LinearMpc(wood_berry.model, wood_berry.mpc)
    kept = controller.applied_inputs.shape[0] + controller._history.shape[0]
    u, _, steps, after = _run(controller, FoptdPlant(truth, 0.0, 0), r, switch_at=700, new_model=truth)
    assert np.max(np.abs(steps[600:700])) > 0.05  # the wrong model's residual
    # model = plant: nothing left to explain but what the inputs before the history kept still do to the outputs,
    # |K| max|u| exp(-kept / tau) per element, decaying
    left = np.abs(truth.gain) * np.abs(u).max(axis=0) * np.exp(-kept / truth.time_constant)
    np.testing.assert_allclose(steps[701:], 0.0, atol=float(left.sum(axis=1).max()))
    np.testing.assert_allclose(steps[-100:], 0.0, atol=1e-9)
    assert after.model is truth and after.statistics.steps == len(r)


def test_an_integrating_output_switches_without_a_bump():
    config = load_config("config/industrial_column.yaml")
    model = config.model
    r = np.zeros((1500, model.n_outputs))
    r[100:] = 0.2
    new = replace(model, gain=model.gain * 1.2)
    plant = FoptdPlant(model, 0.0, 0)
    u, y, _, after = _run(LinearMpc(model, config.mpc), plant, r, switch_at=1400, new_model=new)
    assert after.estimator.n_ramps > 0
    np.testing.assert_allclose(y[1390:], r[1390:], atol=1e-6)
    np.testing.assert_allclose(u[1400:], np.tile(u[1399], (100, 1)), atol=1e-6)


def test_a_model_of_other_channels_or_sample_time_is_refused(wood_berry):
    controller = LinearMpc(wood_berry.model, wood_berry.mpc)
    with pytest.raises(ValueError, match="channels .* are not the controller"):
        controller.switched(replace(wood_berry.model, output_names=("a", "b")))
    with pytest.raises(ValueError, match="sample time"):
        controller.switched(replace(wood_berry.model, sample_time=2.0))


def test_the_applied_inputs_are_the_newest_kept_oldest_first(wood_berry):
    controller = LinearMpc(wood_berry.model, wood_berry.mpc)
    kept = controller._history.shape[0]
    rng = np.random.default_rng(5)
    applied = np.array([controller.step(rng.normal(size=2), rng.normal(size=2)) for _ in range(kept + 7)])
    np.testing.assert_array_equal(controller.applied_inputs, applied[-kept:])
    controller.reset()
    assert controller.applied_inputs.shape == (0, 2)
