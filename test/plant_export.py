"""Test helpers: a decentralized PI loop, and a simulated run exported as a (dirty) historian file.

:func:`export_frame` writes any :class:`Record` as a historian export: DV
columns, no setpoint column for a zone CV, and per-MV mode tags from
``Record.manual``; :meth:`ExportTags.data_block` is the ``data`` block that
reads it back.

The PI loop is the "other controller" of the plant-data tests (the product has
only the MPC): two velocity-form PI loops on the Wood-Berry column, x_D by
reflux and x_B by steam, with Luyben's BLT tuning (Kc = 0.375, 1/tau_I = 1/8.29;
Kc = -0.075, 1/tau_I = 1/23.6; Luyben 1986, Ind. Eng. Chem. Process Des. Dev. 25, 654).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
import pandas as pd

from pmr_ros.core.records import Record
from pmr_ros.core.sim.excitation import PrbsGenerator
from pmr_ros.core.sim.true_plant import FoptdPlant

PI_GAIN = np.array([0.375, -0.075])
PI_RESET_MIN = np.array([8.29, 23.6])
START = "2024-03-01T00:00:00Z"


def pi_loop(config, samples: int, seed: int) -> Record:
    """The Wood-Berry column under two PI loops (pairing 1-1, 2-2), PRBS setpoints, the configured mismatch."""
    plant = FoptdPlant(config.plant(), config.noise_std, seed, disturbance=config.disturbance)
    r = PrbsGenerator(config.prbs, seed).sequence(samples)
    ts = config.model.sample_time
    u = np.empty((samples, 2))
    y = np.empty((samples, 2))
    last_error = np.zeros(2)
    u_now = np.zeros(2)
    for k in range(samples):
        y[k] = plant.measure()
        error = r[k] - y[k]
        u_now = u_now + PI_GAIN * (error - last_error + ts / PI_RESET_MIN * error)
        last_error = error
        u[k] = u_now
        plant.advance(u[k])
    return Record(r, u, y)


TAGS = {"r": ("XC101.SP", "XC102.SP"), "u": ("FC201.OP", "FC202.OP"), "y": ("XI101.PV", "XI102.PV")}
"""Historian tag names of the exported channels (x_D, x_B; reflux, steam)."""

NOMINAL = {"r": np.array([96.0, 0.5]), "u": np.array([1.95, 1.71]), "y": np.array([96.0, 0.5])}
"""Operating point added to the deviation variables: a historian stores absolute values."""

DATA_BLOCK = {
    "time_column": "Timestamp",
    "time_unit_s": 60.0,
    "setpoint_columns": list(TAGS["r"]),
    "input_columns": list(TAGS["u"]),
    "output_columns": list(TAGS["y"]),
    "mode_column": "XC_MODE",
    "mode_on_values": ["AUTO"],
}
"""The ``data`` block that maps the export's tags onto the model's channels."""


@dataclass(frozen=True)
class Dirt:
    """Where an export was made dirty (rows), so a test knows what must be excluded."""

    sentinels: list[int]
    frozen: list[tuple[int, int]]
    controller_off: tuple[int, int]
    dropped: list[int]


def clean_frame(record: Record, *, jitter_s: float = 0.0, seed: int = 0) -> pd.DataFrame:
    """The run as a historian would export it: ISO stamps every minute, one column per tag, mode AUTO."""
    n = record.r.shape[0]
    rng = np.random.default_rng(seed)
    stamps = pd.Timestamp(START) + pd.to_timedelta(60.0 * np.arange(n) + rng.uniform(-jitter_s, jitter_s, n), "s")
    frame = pd.DataFrame({"Timestamp": stamps.strftime("%Y-%m-%dT%H:%M:%S.%fZ")})
    for signal, tags in TAGS.items():
        values = getattr(record, signal) + NOMINAL[signal]
        for j, tag in enumerate(tags):
            frame[tag] = values[:, j]
    frame["XC_MODE"] = "AUTO"
    return frame


def dirty_frame(record: Record, *, seed: int = 0) -> tuple[pd.DataFrame, Dirt]:
    """:func:`clean_frame` with realistic dirt, and where it is.

    Sentinels, "Bad" and empty cells, a frozen tag, the controller off for a
    while (its data then meaningless), a few rows lost, a repeated row and
    jittered stamps.
    """
    n = record.r.shape[0]
    rng = np.random.default_rng(seed)
    frame = clean_frame(record, jitter_s=6.0, seed=seed).astype(object)
    sentinels = sorted(rng.choice(np.arange(200, n - 200), size=12, replace=False).tolist())
    for j, row in enumerate(sentinels):
        tag = [*TAGS["y"], *TAGS["u"]][j % 4]
        frame.loc[row, tag] = (-9999, "Bad", "", -10000)[j % 4]
    frozen = []
    for start in (int(0.3 * n), int(0.7 * n)):
        frame.loc[start : start + 59, TAGS["y"][0]] = frame.loc[start, TAGS["y"][0]]
        frozen.append((start, start + 60))
    off = (int(0.5 * n), int(0.5 * n) + 600)
    frame.loc[off[0] : off[1] - 1, "XC_MODE"] = "MAN"
    frame.loc[off[0] : off[1] - 1, TAGS["u"][0]] = 3.0  # the operator's manual moves: no controller in them
    dropped = [int(0.9 * n) + j for j in range(5)]
    frame = frame.drop(index=dropped)
    repeated = frame.loc[[int(0.2 * n)]]
    frame = pd.concat([frame, repeated]).sort_index(kind="stable").reset_index(drop=True)
    return frame, Dirt(sentinels, frozen, off, dropped)


def as_parquet_frame(frame: pd.DataFrame) -> pd.DataFrame:
    """A dirty frame as a typed Parquet export holds it: date-time stamps, float columns, nulls for bad strings."""
    out = pd.DataFrame({"Timestamp": pd.to_datetime(frame["Timestamp"], utc=True, format="ISO8601")})
    for tag in [t for tags in TAGS.values() for t in tags]:
        out[tag] = pd.to_numeric(frame[tag].replace({"Bad": None, "": None}), errors="raise").astype(float)
    out["XC_MODE"] = frame["XC_MODE"].astype(str)
    return out


@dataclass(frozen=True)
class ExportTags:
    """The tags of an export, one per channel; a setpoint tag ``""`` writes no column (a zone CV).

    ``modes`` are the per-MV mode tags written from ``Record.manual`` (none: no mode column);
    ``dither`` the logged MV dither of a step tester (none: not exported).
    """

    r: tuple[str, ...]
    u: tuple[str, ...]
    y: tuple[str, ...]
    dv: tuple[str, ...] = ()
    modes: tuple[str, ...] = ()
    time: str = "Timestamp"
    dither: tuple[str, ...] = ()

    def data_block(self, *, on: str = "AUTO") -> dict[str, Any]:
        """The ``data`` block that maps these tags onto the model's channels (minutes)."""
        block: dict[str, Any] = {
            "time_column": self.time,
            "time_unit_s": 60.0,
            "setpoint_columns": list(self.r),
            "input_columns": list(self.u),
            "output_columns": list(self.y),
            "disturbance_columns": list(self.dv),
            "mode_columns": list(self.modes),
            "dither_columns": list(self.dither),
        }
        return block | ({"mode_on_values": [on]} if self.modes else {})


def export_tags(config, *, dither: bool = False) -> ExportTags:
    """Tags of a simulated run of ``config``: ``r_``, ``u_``, ``y_``, ``d_``, ``mode_`` + channel; no zone CV setpoint.

    The DVs are the configuration's (its disturbance model, else ``system.disturbance_names``),
    the zone CVs those of ``mpc.output_mode``; ``dither``: the MV dither too (``dither_`` + MV).
    """
    from pmr_ros.config.data import ZONE, configured_disturbances, output_modes

    model = config.model
    zone = output_modes(config.parameters, len(model.output_names))
    return ExportTags(
        r=tuple("" if zone[i] == ZONE else f"r_{name}" for i, name in enumerate(model.output_names)),
        u=tuple(f"u_{name}" for name in model.input_names),
        y=tuple(f"y_{name}" for name in model.output_names),
        dv=tuple(f"d_{name}" for name in configured_disturbances(config)),
        modes=tuple(f"mode_{name}" for name in model.input_names),
        dither=tuple(f"dither_{name}" for name in model.input_names) if dither else (),
    )


def export_frame(
    record: Record,
    tags: ExportTags,
    *,
    nominal: dict[str, np.ndarray] | None = None,
    on: str = "AUTO",
    off: str = "MAN",
) -> pd.DataFrame:
    """A record as a historian exports it: ISO stamps every minute, a column per tag, per-MV modes.

    Parameters
    ----------
    record : Record
        Its ``dv`` is written to ``tags.dv``, its ``manual`` as ``off``/``on`` to ``tags.modes``.
    tags : ExportTags
    nominal : dict, optional
        Signal (``r``, ``u``, ``y``, ``dv``) to the operating point added to it.
    on, off : str
        The mode tags' values.
    """
    n = record.samples
    stamps = pd.Timestamp(START) + pd.to_timedelta(60.0 * np.arange(n), "s")
    frame = pd.DataFrame({tags.time: stamps.strftime("%Y-%m-%dT%H:%M:%S.%fZ")})
    for signal in ("r", "u", "y", "dv", "dither"):
        names = getattr(tags, signal)
        if not names:
            continue
        values = np.asarray(getattr(record, signal), dtype=float) + (nominal or {}).get(signal, 0.0)
        for j, tag in enumerate(names):
            if tag:
                frame[tag] = values[:, j]
    manual = np.zeros(np.shape(record.u), dtype=bool) if record.manual is None else record.manual
    for k, tag in enumerate(tags.modes):
        frame[tag] = np.where(manual[:, k], off, on)
    return frame
