"""Diagnosing a simulated record with the configuration it ran (shared by the tests)."""

from __future__ import annotations

from pmr_ros.config import PmrConfig
from pmr_ros.core.pmr.diagnosis import diagnose
from pmr_ros.core.records import Record
from pmr_ros.core.results import Diagnosis


def diagnose_record(record: Record, config: PmrConfig, *, method: str, with_dither: bool = False) -> Diagnosis:
    """``diagnose`` of ``record`` with ``config``'s model and settings; its MV dither as instruments if asked."""
    return diagnose(
        record.r,
        record.u,
        record.y,
        model=config.model,
        pmr=config.pmr,
        parametric=config.parametric,
        method=method,
        dither=record.dither if with_dither else None,
    )
