"""How many days of routine data decide a +10 % gain change? (prints a table, writes a figure).

Two plants at Ts = 1 min -- Wood-Berry (``config/wood_berry.yaml``) and the debutanizer
(``config/debutanizer_routine.yaml``) -- each with one injected change only, G11's gain +10 %
(every other element and every DV element as the model), in three settings of routine operation:

* ``steps``: rare operator setpoint steps only (``prbs.mode: steps``, one every 4 h on average per
  setpoint CV), no dither, no manual stretches, the DVs standing still;
* ``dither``: the same plus a small MV dither (Wood-Berry +/- 0.02 lb/min, the debutanizer its file's);
* ``dvs``: the same plus measured DVs moving as random steps (the debutanizer its file's two;
  Wood-Berry two DVs added here: the feed rate with Wood and Berry's own feed model,
  3.8 e-8s/(14.9s+1) and 4.9 e-3s/(13.2s+1) (their 8.1 and 3.4 min delays rounded to whole samples),
  and a feed composition with a made-up but sensible model, 0.6 e-4s/(12s+1) and 1.1 e-5s/(15s+1)).

One long run per setting and seed is simulated and growing prefixes of it (1, 2, 4, 7, 14, 28, 56
days) are diagnosed.  A prefix *decides* when G11's verdict is ``mismatch`` with its dK within 3
percentage points of +10 and no other element is ``mismatch``.  Printed per plant and setting: the
first deciding length (``> N d`` when none does), and per length the fraction of the G elements
whose verdict is not ``inconclusive``.

Run: nice -n 10 .venv/bin/python benchmarks/bench_routine.py [--days 56] [--seeds 1,2]
     [--plants wood_berry,debutanizer] [--figure docs/figures/routine_days.png]
"""

from __future__ import annotations

import argparse
import time
from collections.abc import Mapping, Sequence
from dataclasses import fields
from typing import Any

import numpy as np

from pmr_ros.config import PmrConfig, config_dir, load_config
from pmr_ros.core.pmr.diagnosis import diagnose_stretches
from pmr_ros.core.records import Record
from pmr_ros.core.sim.closed_loop import simulate

DAY = 24 * 60
"""Samples per day at Ts = 1 min."""
LENGTHS_DAYS = (1, 2, 4, 7, 14, 28, 56)
"""The prefixes diagnosed [days]."""
INJECTED, INJECTED_PCT, GAIN_PP = "G11", 10.0, 3.0
"""The one injected change (G11's gain +10 %) and the specification of its estimate [pp]."""
SETTINGS = ("steps", "dither", "dvs")
PLANTS = {"wood_berry": "wood_berry.yaml", "debutanizer": "debutanizer_routine.yaml"}

WOOD_BERRY_DVS: dict[str, Any] = {
    "disturbance_names": ["feed", "feed_x"],
    "disturbance_element_type": ["foptd"] * 4,
    "disturbance_gain": [3.8, 0.6, 4.9, 1.1],
    "disturbance_time_constant": [14.9, 12.0, 13.2, 15.0],
    "disturbance_delay": [8.0, 4.0, 3.0, 5.0],
}
"""Wood-Berry's DVs (row-major, x_D then x_B): feed rate (Wood & Berry's model) and feed composition."""


def _zeros(n: int) -> list[float]:
    return [0.0] * n


def overrides(plant: str, setting: str, *, seed: int, samples: int) -> dict[str, Any]:
    """The configuration overrides of ``plant`` in ``setting`` (one of :data:`SETTINGS`).

    Parameters
    ----------
    plant : str
        ``wood_berry`` or ``debutanizer``.
    setting : str
    seed : int
    samples : int
        Length of the run [samples].
    """
    n_out, n_in = (2, 2) if plant == "wood_berry" else (4, 8)
    gain = _zeros(n_out * n_in)
    gain[0] = INJECTED_PCT
    mismatch: dict[str, Any] = {"gain_pct": gain, "time_constant_pct": _zeros(n_out * n_in)}
    mismatch["delay_samples"] = [0] * (n_out * n_in)
    out: dict[str, Any] = {"mismatch": mismatch, "run": {"seed": seed, "samples": samples, "scenario": "full"}}
    if plant == "wood_berry":
        out["system"] = dict(WOOD_BERRY_DVS)
        out["prbs"] = {"mode": "steps", "step_interval_samples": 240.0, "step_amplitude": [1.0, 1.0]}
        dither, dv_amplitude = [0.02, 0.02], [1.0, 0.5]
        out["disturbance_signal"] = {"kind": ["steps", "steps"], "mean_interval_samples": [180.0, 480.0]}
    else:
        mismatch["disturbance_gain_pct"] = _zeros(n_out * 2)
        out["run"]["manual_stretches"] = []
        out["prbs"] = {"step_interval_samples": 240.0}
        base = load_config(config_dir() / PLANTS[plant])
        dither = [float(a) for a in base.excitation.mv_dither_amplitude]
        dv_amplitude = [2.0, 1.0]
        out["disturbance_signal"] = {}
    out["excitation"] = {"mv_dither_amplitude": dither if setting != "steps" else _zeros(n_in)}
    out["disturbance_signal"]["amplitude"] = dv_amplitude if setting == "dvs" else _zeros(2)
    return out


def prefix(record: Record, samples: int) -> Record:
    """The first ``samples`` rows of ``record`` (every per-sample field cut alike)."""
    cut = {f.name: getattr(record, f.name) for f in fields(record)}
    return Record(**{k: None if v is None else np.asarray(v)[:samples] for k, v in cut.items()})


def decided(elements: Mapping[str, Any]) -> bool:
    """Whether a diagnosis decides: G11 ``mismatch`` with dK within 3 pp of +10 %, no other ``mismatch``.

    Parameters
    ----------
    elements : mapping of str to ElementDiagnosis
        The diagnosis's elements (``verdict``, ``parametric.gain_mismatch_pct``).
    """
    for name, element in elements.items():
        if name != INJECTED and element.verdict == "mismatch":
            return False
    target = elements.get(INJECTED)
    if target is None or target.verdict != "mismatch" or target.parametric is None:
        return False
    return bool(abs(target.parametric.gain_mismatch_pct - INJECTED_PCT) <= GAIN_PP)


def decided_fraction(elements: Mapping[str, Any]) -> float:
    """The fraction of the plant's G elements whose verdict is not ``inconclusive``.

    The DV elements (D11, ...) are left out: in the settings where the DVs stand still nothing
    can decide them, and counting them would make the settings incomparable.
    """
    verdicts = [e.verdict for name, e in elements.items() if name.startswith("G")]
    return sum(v != "inconclusive" for v in verdicts) / max(1, len(verdicts))


def run_case(config: PmrConfig, lengths: Sequence[int]) -> list[tuple[int, bool, float]]:
    """Simulate ``config`` once and diagnose each prefix of ``lengths`` days: (days, decides, decided fraction)."""
    record = simulate(config)
    rows = []
    for days in lengths:
        diagnosis = diagnose_stretches(
            [prefix(record, days * DAY)],
            model=config.model,
            pmr=config.pmr,
            parametric=config.parametric,
            disturbance_model=config.disturbance_model,
        )
        # a too-short prefix is refused (insufficient_data) with every element inconclusive
        rows.append((days, decided(diagnosis.elements), decided_fraction(diagnosis.elements)))
    return rows


def _plot(results: Mapping[tuple[str, str], list[list[tuple[int, bool, float]]]], path: str) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, len(PLANTS), figsize=(9, 3.5), sharey=True)
    for ax, plant in zip(np.atleast_1d(axes), PLANTS, strict=False):
        for setting in SETTINGS:
            runs = results.get((plant, setting))
            if not runs:
                continue
            days = [d for d, _, _ in runs[0]]
            frac = np.mean([[f for _, _, f in run] for run in runs], axis=0)
            first = [min((d for d, ok, _ in run if ok), default=None) for run in runs]
            label = f"{setting} (decides: {', '.join(f'{d} d' if d else '-' for d in first)})"
            ax.semilogx(days, frac, marker="o", label=label)
        ax.set(title=plant, xlabel="days of routine data", xticks=LENGTHS_DAYS, xticklabels=LENGTHS_DAYS)
        if ax.get_lines():  # a plant not run yet has no curve to name
            ax.legend(fontsize=7)
    np.atleast_1d(axes)[0].set_ylabel("fraction of G elements decided")
    fig.tight_layout()
    fig.savefig(path, dpi=100)


def main(argv: Sequence[str] | None = None) -> None:
    """Run the benchmark and print its table."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--days", type=int, default=56)
    parser.add_argument("--seeds", default="1")
    parser.add_argument("--plants", default=",".join(PLANTS))
    parser.add_argument("--settings", default=",".join(SETTINGS))
    parser.add_argument("--figure", default="")
    args = parser.parse_args(argv)
    lengths = [d for d in LENGTHS_DAYS if d <= args.days]
    results: dict[tuple[str, str], list[list[tuple[int, bool, float]]]] = {}
    print(f"{'plant':12s} {'setting':7s} seed  first  " + " ".join(f"{d:>5d}d" for d in lengths), flush=True)
    for plant in args.plants.split(","):
        for setting in args.settings.split(","):
            for seed in (int(s) for s in args.seeds.split(",")):
                start = time.perf_counter()
                changes = overrides(plant, setting, seed=seed, samples=args.days * DAY)
                config = load_config(config_dir() / PLANTS[plant], overrides=changes)
                rows = run_case(config, lengths)
                results.setdefault((plant, setting), []).append(rows)
                first = next((f"{d} d" for d, ok, _ in rows if ok), f"> {args.days} d")
                cells = " ".join(f"{f:6.2f}" for _, _, f in rows)
                took = time.perf_counter() - start
                print(f"{plant:12s} {setting:7s} {seed:4d}  {first:>6s} {cells}   ({took:.0f} s)", flush=True)
                if args.figure:  # after every case: a long run cut short still leaves its figure
                    _plot(results, args.figure)


if __name__ == "__main__":
    main()
