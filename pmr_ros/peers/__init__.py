"""Peer methods of model-plant mismatch detection, each in the same per-element shape, for the benchmark.

* :func:`partial_correlation_test`: partial correlation of each CV's
  pre-whitened model residual with each MV (Badwe, Gudi, Patwardhan et al.,
  J. Process Control 19, 2009);
* :func:`pem_diagnosis`: direct closed-loop prediction-error identification
  of each row as a MISO FOPTD, output error or Box-Jenkins;
* :func:`classic_pmr`: the project's classic PMR (the seed paper's Table 1);
* :func:`from_diagnosis`: any project ``Diagnosis`` (e.g. the parametric PMR) in the same shape.

Every function returns ``{element name: PeerOutcome}``, row-major.  Numpy and
scipy only; nothing here imports ROS or the command layer.
"""

from __future__ import annotations

from .classic_pmr import classic_pmr
from .outcome import PeerOutcome, Tolerances, from_diagnosis
from .partial_correlation import partial_correlation_test
from .pem import NOISE_MODELS, pem_diagnosis

__all__ = [
    "NOISE_MODELS",
    "PeerOutcome",
    "Tolerances",
    "classic_pmr",
    "from_diagnosis",
    "partial_correlation_test",
    "pem_diagnosis",
]
