"""``pmr-ros run --batch``: the configured closed loop simulated in this process, diagnosed, the loop closed."""

from __future__ import annotations

from ..config import PmrConfig
from ..core.pmr.diagnosis import diagnose_stretches
from ..core.results import Diagnosis
from ..core.sim.closed_loop import simulate
from .closing import close_and_write

__all__ = ["simulate_and_diagnose"]


def simulate_and_diagnose(
    config: PmrConfig, *, model_path: str | None = None, notes: list[str] | None = None
) -> Diagnosis:
    """Simulate ``config``'s run (``run.samples``, ``run.seed``, ``run.scenario``) and diagnose it.

    The diagnosis carries the data-quality figures of the ``quality`` block
    and, for a mismatch, the control impact; ``model_path`` receives the
    corrected model (``--write-model``); ``notes`` receives why the control
    impact was not computed, when it was skipped.

    Raises
    ------
    ServiceError
        ``model_path`` with a diagnosis that cannot give a corrected model.
    """
    diagnosis = diagnose_stretches(
        [simulate(config)],
        model=config.model,
        pmr=config.pmr,
        parametric=config.parametric,
        quality=config.quality,
        disturbance_model=config.disturbance_model,
    )
    return close_and_write(config, diagnosis, model_path=model_path, notes=notes)
