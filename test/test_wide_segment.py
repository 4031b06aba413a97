"""The parametric method's automatic Welch segment holds enough bins for a wide row (issue 25, item 6).

A row of n columns needs 2 n + 2 fitted bins; under the default excitation the informative band ends near
0.7 rad/sample, 57 bins of a 512-sample segment.  Measured on a 32 x 32 half-empty unit at 65,536 samples:
0 of 512 modelled elements within specification with 512 samples a segment, 407 with 1024.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from pmr_ros.config import load_config
from pmr_ros.core.pmr.parametric.settings import FIT_BAND
from pmr_ros.core.sim.model import TransferMatrix


def _unit(n: int) -> TransferMatrix:
    """An n x n unit of first-order elements with time constants of 6 samples (the slowest asks for 256)."""
    return TransferMatrix(np.ones((n, n)), np.full((n, n), 6.0), np.zeros((n, n)), 1.0)


@pytest.mark.parametrize(("inputs", "segment"), [(2, 512), (16, 512), (27, 512), (28, 1024), (32, 1024), (48, 1024)])
def test_the_segment_grows_with_the_columns_a_row_fits(inputs, segment):
    config = load_config(None)
    welch = config.parametric.welch(_unit(inputs), 65536, config.pmr)
    assert welch.segment_length == segment
    band_bins = math.floor(FIT_BAND / (2.0 * math.pi / welch.segment_length))
    assert band_bins >= 2 * inputs + 2  # the guard's least for a row of every input


def test_a_short_record_still_caps_the_segment():
    config = load_config(None)
    assert config.parametric.welch(_unit(32), 3000, config.pmr).segment_length == 512  # a quarter of the record
