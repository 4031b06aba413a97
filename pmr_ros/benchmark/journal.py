"""The benchmark's journal: each finished run's result rows on disk at once, so a stopped benchmark resumes.

A full benchmark is hours of CPU; a run that ends by a kill, a reboot or a
lost cluster would otherwise lose every result, since ``results.parquet`` is
written once at the end.  Each run's rows go to their own small Parquet file
in the journal folder the moment the run is done (atomically: a file is
whole or absent), one file per run and set of methods
(``runs/run_00105.parametric+classic.parquet``), so that
``pmr-ros benchmark --resume`` skips every (run, method) pair already there
and runs only the rest.  Run numbers mean something only in their
scenario file, so the journal keeps a fingerprint of it (``journal.json``) and
:meth:`Journal.check` refuses to continue with another.
"""

from __future__ import annotations

import hashlib
import json
from collections.abc import Iterable
from pathlib import Path
from typing import TYPE_CHECKING

from ..outputs import replacing, write_text

if TYPE_CHECKING:
    import pandas as pd  # annotations only: pandas is the data extra, imported where used

__all__ = ["Journal", "fingerprint"]

KEY_FILE = "journal.json"
"""Beside the pieces: the fingerprint of the scenario file the run numbers belong to."""


def fingerprint(scenarios: pd.DataFrame) -> str:
    """A SHA-256 of the scenario lines (their CSV text): equal exactly when every line is."""
    return hashlib.sha256(scenarios.to_csv(index=False).encode()).hexdigest()


class Journal:
    """The journal folder of one benchmark output folder.

    Parameters
    ----------
    folder : Path
        Where the pieces go (created on the first write).

    Examples
    --------
    >>> import tempfile
    >>> journal = Journal(Path(tempfile.mkdtemp()) / "runs")
    >>> journal.write(7, ("classic",), [{"run": 7, "method": "classic", "element": "G11", "detected": True}])
    >>> sorted(journal.done())
    [(7, 'classic')]
    """

    PATTERN = "run_*.parquet"

    def __init__(self, folder: Path) -> None:
        self.folder = Path(folder)

    def _pieces(self) -> list[Path]:
        return sorted(self.folder.glob(self.PATTERN)) if self.folder.is_dir() else []

    def write(self, run: int, methods: Iterable[str], rows: list[dict]) -> None:
        """Keep ``rows`` (result rows of ``run``, by :func:`~pmr_ros.benchmark.runner.method_rows`) on disk now."""
        import pandas as pd

        self.folder.mkdir(parents=True, exist_ok=True)
        path = self.folder / f"run_{run:05d}.{'+'.join(methods)}.parquet"
        with replacing(path) as tmp:
            pd.DataFrame(rows).to_parquet(tmp, index=False)

    def read(self) -> pd.DataFrame:
        """Every piece's rows (an empty frame when there is none); a later piece of a (run, method) wins."""
        import pandas as pd

        pieces = sorted(self._pieces(), key=lambda p: p.stat().st_mtime_ns)
        frames = [pd.read_parquet(p).assign(_piece=i) for i, p in enumerate(pieces)]
        frames = [f for f in frames if not f.empty]
        if not frames:
            return pd.DataFrame(columns=["run", "method", "element"])
        rows = pd.concat(frames, ignore_index=True)
        newest = rows.groupby(["run", "method"])["_piece"].transform("max")
        return rows[rows["_piece"] == newest].drop(columns="_piece").reset_index(drop=True)

    def seed(self, rows: pd.DataFrame) -> int:
        """Write ``rows`` (result rows of many runs and methods) as pieces, one per (run, method); how many.

        How a results.parquet (a committed or downloaded one, with no journal beside it) becomes a journal
        that ``--resume`` continues.
        """
        pairs = rows.groupby(["run", "method"], sort=True)
        for (run, method), piece in pairs:
            self.write(int(run), (str(method),), piece.to_dict("records"))
        return pairs.ngroups

    def done(self) -> set[tuple[int, str]]:
        """The (run, method) pairs with rows in the journal."""
        rows = self.read()
        return {(int(r), str(m)) for r, m in zip(rows["run"], rows["method"], strict=True)}

    def count(self) -> int:
        """How many pieces there are."""
        return len(self._pieces())

    def start(self, key: str) -> None:
        """Begin a new journal for the scenario file of fingerprint ``key``: every piece removed."""
        for piece in self._pieces():
            piece.unlink()
        self.folder.mkdir(parents=True, exist_ok=True)
        write_text(self.folder / KEY_FILE, json.dumps({"scenarios": key}) + "\n")

    def check(self, key: str) -> None:
        """Continue this journal with the scenario file of fingerprint ``key`` (a journal not begun is begun).

        Raises
        ------
        ValueError
            The journal's runs belong to another scenario file.
        """
        path = self.folder / KEY_FILE
        if not path.is_file():
            if self.count():
                raise ValueError(f"{path} is missing: the journal's scenario file is unknown")
            self.start(key)
            return
        kept = json.loads(path.read_text()).get("scenarios")
        if kept != key:
            raise ValueError(f"{self.folder} holds the runs of another scenario file (fingerprint {str(kept)[:12]})")
