"""The service layer's own parts: which limits a file gave, closing the loop, saturation on the data as read."""

from __future__ import annotations

import argparse
from dataclasses import replace

import numpy as np
import pytest
import yaml

from pmr_ros.commands.arguments import add_options, config_option, option
from pmr_ros.config import load_config
from pmr_ros.core.pmr.data_quality import assess
from pmr_ros.core.records import Record
from pmr_ros.core.results import Diagnosis
from pmr_ros.service.closing import close_and_write
from pmr_ros.service.historian import limits_given
from pmr_ros.service.refusal import EXIT_INSUFFICIENT, ServiceError


def _params(tmp_path, **blocks):
    """A params file of the shipped system with ``blocks`` added."""
    shipped = yaml.safe_load(open("config/wood_berry.yaml", encoding="utf-8"))
    tree = next(iter(shipped.values()))["ros__parameters"]
    tree = {"system": tree["system"], **blocks}
    path = tmp_path / "plant.yaml"
    path.write_text(yaml.safe_dump({"/**": {"ros__parameters": tree}}), encoding="utf-8")
    return path


def test_limits_count_as_given_only_when_the_file_sets_both(tmp_path):
    assert not limits_given(load_config(_params(tmp_path)))
    assert not limits_given(load_config(_params(tmp_path, mpc={"u_min": [-1.0, -1.0]})))
    both = load_config(_params(tmp_path, mpc={"u_min": [-1.0, -1.0], "u_max": [1.0, 1.0]}))
    assert limits_given(both) and {"mpc.u_min", "mpc.u_max", "system.gain"} <= both.given


def test_closing_a_diagnosis_without_verdicts_writes_no_model(tmp_path):
    config = load_config()
    diagnosis = Diagnosis.insufficient(
        method="parametric", models=config.model.element_models(), reason="too short", samples=10
    )
    assert close_and_write(config, diagnosis) is diagnosis
    target = tmp_path / "model.yaml"
    with pytest.raises(ServiceError) as refused:
        close_and_write(config, diagnosis, model_path=str(target))
    assert refused.value.code == EXIT_INSUFFICIENT and str(target) in str(refused.value)
    assert not target.exists()


def test_saturation_is_judged_on_the_data_as_read_the_spectra_on_the_deviations():
    config = load_config()
    rng = np.random.default_rng(0)
    n = 4096
    r, y = rng.standard_normal((n, 2)), rng.standard_normal((n, 2))
    u = np.clip(rng.standard_normal((n, 2)), -1.0, 1.0)
    deviations = Record(r - r.mean(0), u - u.mean(0), y - y.mean(0))
    as_read = Record(r, u + 5.0, y)  # read 5 units up: the deviations never reach a limit at 6
    settings = replace(config.quality, u_min=np.array([4.0, 4.0]), u_max=np.array([6.0, 6.0]))
    kw = {"model": config.model, "welch": config.pmr.welch, "settings": settings}
    own = assess([deviations], **kw)
    read = assess([deviations], **kw, as_read=[as_read])
    clipped = np.mean(np.abs(u) >= 1.0 - settings.limit_tolerance * 2.0, axis=0)
    np.testing.assert_allclose(read.saturated, clipped, atol=0.01)
    np.testing.assert_array_equal(own.outside, 1.0)  # deviations lie all below u_min = 4
    np.testing.assert_allclose(read.low_frequency, own.low_frequency, rtol=1e-12)


def test_an_option_table_adds_its_options_in_order_under_their_groups():
    parser = argparse.ArgumentParser()
    add_options(
        parser,
        [
            config_option(),
            option("--nu", type=float, default=1.0, group="grid"),
            option("--seeds", type=int, default=5),
        ],
    )
    args = parser.parse_args(["--nu", "2.5", "--config", "x.yaml"])
    assert (args.config, args.nu, args.seeds) == ("x.yaml", 2.5, 5)
    titles = [g.title for g in parser._action_groups]
    assert "grid" in titles
    assert [a.dest for a in parser._actions][1:] == ["config", "nu", "seeds"]
    assert config_option("other help").but(dest="source").settings == {
        "metavar": "FILE",
        "help": "other help",
        "dest": "source",
    }
