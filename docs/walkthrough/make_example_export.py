"""Write the walkthrough's example historian export: a simulated Wood-Berry MPC run, exported with dirt.

    .venv/bin/python docs/walkthrough/make_example_export.py runs/historian.csv

The run is ``pmr-ros run --batch``'s (the shipped mismatch, seed 1, 16,384 samples of 1 min);
the export is the one the tests make (test/plant_export.py): historian tags, ISO time stamps
with a few seconds of jitter, operating-point values, bad-value sentinels, "Bad" and empty
cells, a frozen analyzer, the controller in manual for 10 hours, lost and repeated rows.
"""

from __future__ import annotations

import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "test"))

from plant_export import as_parquet_frame, dirty_frame  # noqa: E402

from pmr_ros.config import load_config  # noqa: E402
from pmr_ros.core.sim.closed_loop import simulate  # noqa: E402


def main(argv: list[str]) -> int:
    """Write the export to the path given (.csv or .parquet)."""
    if len(argv) != 1 or Path(argv[0]).suffix not in (".csv", ".parquet"):
        print("usage: make_example_export.py OUT.csv|OUT.parquet", file=sys.stderr)
        return 2
    out = Path(argv[0])
    out.parent.mkdir(parents=True, exist_ok=True)
    frame, _ = dirty_frame(simulate(load_config(), samples=16384, seed=1), seed=3)
    if out.suffix == ".csv":
        frame.to_csv(out, index=False)
    else:
        as_parquet_frame(frame).to_parquet(out)
    print(f"wrote {out}: {len(frame)} rows, columns {', '.join(frame.columns)}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
