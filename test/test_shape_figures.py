"""The report's figure of a plant that differs in shape: drawn and embedded for every element named so, not blank."""

from __future__ import annotations

import base64
import io
import re
from dataclasses import replace
from functools import cache

import numpy as np
from PIL import Image
from test_parametric_general import CONFIG, _diagnose, _foptd_fit_model, _second_order_plant, _step_test

from pmr_ros.core.pmr.curves import pmr_curves
from pmr_ros.core.pmr.parametric.shape import SHAPE_REASON
from pmr_ros.data.clean import PlantData
from pmr_ros.report.html import ReportInput, write_html_report
from pmr_ros.report.shape_figures import differs_in_shape, plant_phase, shape_figure


@cache
def _case():
    """A best FOPTD model of a second-order plant at high signal-to-noise: the shape is seen and named."""
    model = _foptd_fit_model()
    record = _step_test(_second_order_plant(), seed=1)
    return record, _diagnose(record, model), replace(CONFIG, model=model)


def _page(tmp_path):
    record, diagnosis, config = _case()
    names = {"r": config.model.output_names, "u": config.model.input_names, "y": config.model.output_names}
    data = PlantData(
        source="step test",
        start="0",
        sample_time_s=1.0,
        signals={"r": record.r, "u": record.u, "y": record.y},
        columns=names,
        excluded={},
        limited=np.zeros(record.u.shape, dtype=bool),
        steps=(),
        manual=record.manual,
    )
    report = {"system": "second-order plant", "source": "step test", "version": "test"}
    return write_html_report(tmp_path, ReportInput(report, diagnosis, [record], data, config)).read_text()


def _ink(png: bytes) -> float:
    """The share of pixels that are not near white."""
    pixels = np.asarray(Image.open(io.BytesIO(png)).convert("RGB"), dtype=float)
    return float(np.mean(pixels.min(axis=2) < 200))


def _section(html: str, name: str) -> str:
    found = re.search(rf'<section class="element"[^>]*id="{name}">(.*?)</section>', html, re.S)
    assert found is not None, name
    return found.group(1)


def test_every_element_that_differs_in_shape_shows_its_plant_against_the_best_scaled_model(tmp_path):
    _, diagnosis, _ = _case()
    shaped = [e.name for e in diagnosis if e.model.kind != "none" and differs_in_shape(e)]
    assert len(shaped) >= 3  # measured in test_parametric_general: the shape is seen at this noise
    html = _page(tmp_path)
    for element in diagnosis:
        section = _section(html, element.name)
        images = re.findall(r'<figure class="shape"><img src="data:image/png;base64,([^"]+)"', section)
        if element.name not in shaped:
            assert images == [], element.name
            continue
        assert SHAPE_REASON.replace("'", "&#39;") in section, element.name
        assert len(images) == 1, element.name
        png = base64.b64decode(images[0])
        assert png == (tmp_path / "figures" / f"{element.name}_shape.png").read_bytes()
        assert _ink(png) > 0.02, element.name  # axes, points and lines drawn, not a blank canvas


def test_the_figure_draws_the_plant_and_needs_the_models_response():
    record, diagnosis, config = _case()
    curves = pmr_curves([record], diagnosis, config)
    name = next(e.name for e in diagnosis if differs_in_shape(e))
    png = shape_figure(curves[name], diagnosis.elements[name])
    assert png is not None and png.startswith(b"\x89PNG") and _ink(png) > 0.02
    assert shape_figure(replace(curves[name], model_response=None), diagnosis.elements[name]) is None


def test_the_plants_phase_follows_the_reference_through_many_turns():
    w = np.linspace(0.01, np.pi, 200)
    truth = -12.0 * w - np.arctan(8.0 * w)  # a 12-sample delay and a lag: many turns
    rng = np.random.default_rng(2)
    noisy = np.exp(1j * (truth + rng.uniform(-2.5, 2.5, w.size)))  # noise that wrecks a plain unwrap
    phase = np.radians(plant_phase(noisy, np.exp(1j * truth)))
    np.testing.assert_allclose(phase - truth, np.angle(noisy * np.exp(-1j * truth)), atol=1e-9)
    assert np.max(np.abs(phase - truth)) <= 2.5 + 1e-9
