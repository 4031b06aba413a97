"""The prediction-error peer on models of any element type: first-order tf elements judged, other structures not.

Known truths: the injected mismatch recovered exactly on noise-free data by a
model whose elements are first-order tf elements (the FOPTD numbers written
as K/(tau s + 1)), and the row of a second-order tf element left unjudged with
its reason instead of a verdict against a time constant it does not have.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.testing import assert_allclose

from pmr_ros.config import load_config
from pmr_ros.core.sim.model import TransferMatrix
from pmr_ros.core.sim.rational import transfer_function
from pmr_ros.peers import pem_diagnosis
from pmr_ros.peers.pem import foptd_stand_in

NAMES = ("G11", "G12", "G21", "G22")


def _prbs(samples: int, inputs: int, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    return np.repeat(rng.choice([-1.0, 1.0], size=(samples // 10 + 1, inputs)), 10, axis=0)[:samples]


def _as_tf(m: TransferMatrix, order_two: tuple[int, int] | None = None) -> TransferMatrix:
    """``m`` with every element the tf K/(tau s + 1); ``order_two``: that cell K/((tau s + 1)(tau/4 s + 1))."""
    rows = []
    for i in range(m.n_outputs):
        row = []
        for k in range(m.n_inputs):
            gain, tau = float(m.gain[i, k]), float(m.time_constant[i, k])
            den = f"{tau}, 1" if (i, k) != order_two else f"{tau * tau / 4}, {1.25 * tau}, 1"
            row.append(transfer_function(repr(gain), den, delay_samples=int(m.delay_samples[i, k]), sample_time=1.0))
        rows.append(row)
    return TransferMatrix.of_elements(rows, sample_time=1.0, output_names=m.output_names, input_names=m.input_names)


def test_first_order_tf_elements_are_judged_as_the_foptd_elements_they_are():
    config = load_config()
    plant = config.plant("full")
    u = _prbs(2000, 2, seed=3)
    y = plant.element_outputs(u).sum(axis=2)
    as_tf = _as_tf(config.model)
    stand_in, other = foptd_stand_in(as_tf)
    assert not other.any() and list(stand_in.element_type.ravel()) == ["foptd"] * 4
    assert_allclose(stand_in.time_constant, config.model.time_constant, rtol=1e-12)
    foptd = pem_diagnosis(u, y, model=config.model, max_delay_shift=3, start=0)
    tf = pem_diagnosis(u, y, model=as_tf, max_delay_shift=3, start=0)
    m = config.mismatch
    assert_allclose([tf[n].gain_pct for n in NAMES], m.gain_pct.ravel(), rtol=1e-6)
    assert_allclose([tf[n].tau_pct for n in NAMES], m.time_constant_pct.ravel(), rtol=1e-6)
    assert [tf[n].delay_samples for n in NAMES] == m.delay_samples.ravel().tolist()
    assert [tf[n].verdict for n in NAMES] == [foptd[n].verdict for n in NAMES] == ["mismatch"] * 4


def test_a_row_with_a_second_order_tf_element_is_not_judged_and_says_why():
    config = load_config()
    model = _as_tf(config.model, order_two=(0, 1))  # G12 of second order
    plant = model.with_mismatch(config.mismatch.for_scenario("none"))
    u = _prbs(2000, 2, seed=4)
    y = plant.element_outputs(u).sum(axis=2)
    out = pem_diagnosis(u, y, model=model, max_delay_shift=3, start=0)
    for name in ("G11", "G12"):  # the row of G12: no verdict, no number compared with a time constant it lacks
        o = out[name]
        assert o.verdict == "inconclusive" and not o.detected and o.gain_pct is None and o.tau_pct is None
        assert o.reasons == ("G12 is a tf element that is not first order: PEM fits FOPTD elements (as procest "
                             "does), and a row fitted so would be misspecified; not judged",)  # fmt: skip
        assert math.isnan(o.score)
    for name in ("G21", "G22"):  # the other row is FOPTD: judged, and unchanged
        assert out[name].verdict == "ok" and abs(out[name].gain_pct) < 1e-6 and abs(out[name].tau_pct) < 1e-6
