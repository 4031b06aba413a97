"""Write the walkthrough's example historian export: a Wood-Berry column under two PI loops, exported with dirt.

    .venv/bin/python docs/walkthrough/make_example_export.py runs/historian.csv

The loop is the plant-data tests' "controller of one's own" (test/plant_export.py): x_D by
reflux and x_B by steam, velocity-form PI with Luyben's BLT tuning (Kc 0.375 and -0.075,
Ti 8.29 and 23.6 min), setpoints moved by a PRBS.  The plant differs from the model in one
element only: G11's gain is 20 % higher (12.8 -> 15.36 (mol %)/(lb/min)).  16,384 samples of
1 min, seed 1.  The export is the one the tests make: historian tags, ISO time stamps with a
few seconds of jitter, operating-point values, bad-value sentinels, "Bad" and empty cells, a
frozen analyzer, the loops in manual for 10 hours, lost and repeated rows.
"""

from __future__ import annotations

import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "test"))

from plant_export import as_parquet_frame, dirty_frame, pi_loop  # noqa: E402

from pmr_ros.config import load_config  # noqa: E402

MISMATCH = {"gain_pct": [20.0, 0.0, 0.0, 0.0], "time_constant_pct": [0.0] * 4, "delay_samples": [0] * 4}
"""The plant against the model: +20 % on G11's gain, the other three elements as modelled."""


def main(argv: list[str]) -> int:
    """Write the export to the path given (.csv or .parquet)."""
    if len(argv) != 1 or Path(argv[0]).suffix not in (".csv", ".parquet"):
        print("usage: make_example_export.py OUT.csv|OUT.parquet", file=sys.stderr)
        return 2
    out = Path(argv[0])
    out.parent.mkdir(parents=True, exist_ok=True)
    config = load_config(overrides={"mismatch": MISMATCH})
    frame, _ = dirty_frame(pi_loop(config, samples=16384, seed=1), seed=3)
    if out.suffix == ".csv":
        frame.to_csv(out, index=False)
    else:
        as_parquet_frame(frame).to_parquet(out)
    print(f"wrote {out}: {len(frame)} rows, columns {', '.join(frame.columns)}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
