"""``pmr-ros diagnose --fleet``: several controllers, one ranked summary, an index page, a failed entry (issue 25)."""

from __future__ import annotations

import json

import numpy as np
import pandas as pd
import pytest
from drifting import Change, drifting_signals
from shipped import system_only_params

from pmr_ros.cli import main
from pmr_ros.commands.fleet_summary import index_page
from pmr_ros.config import load_config
from pmr_ros.service.fleet import rank_rows, read_fleet
from pmr_ros.service.refusal import ServiceError

DRIFTING = {"C2": Change(0, 0, "gain", day=0, size=18.0), "C3": Change(1, 0, "gain", day=0, size=-25.0)}
"""The two controllers whose plant moved (from the start of their data): G11 +18 %, G21 -25 %."""


def write_export(folder, name, signals, config) -> None:
    stamps = pd.Timestamp("2025-03-01", tz="UTC") + pd.to_timedelta(60.0 * np.arange(signals["y"].shape[0]), "s")
    frame = pd.DataFrame({"time": stamps.strftime("%Y-%m-%dT%H:%M:%SZ")})
    model = config.model
    for signal, names in (("r", model.output_names), ("u", model.input_names), ("y", model.output_names)):
        for j, channel in enumerate(names):
            frame[f"{signal}_{channel}"] = signals[signal][:, j]
    frame.to_csv(folder / f"{name}.csv", index=False)


@pytest.fixture(scope="module")
def fleet(tmp_path_factory):
    config = load_config(None)
    folder = tmp_path_factory.mktemp("fleet")
    (folder / "column.yaml").write_text(system_only_params() + "    data:\n      time_unit_s: 60.0\n")
    entries = []
    for index, name in enumerate(("C1", "C2", "C3")):
        changes = (DRIFTING[name],) if name in DRIFTING else ()
        write_export(folder, name, drifting_signals(config, days=2, changes=changes, seed=10 * index), config)
        entries.append({"name": name, "params": "column.yaml", "data": f"{name}.csv"})
    entries.append({"name": "C4", "params": "column.yaml", "data": "C4.csv"})  # no such file
    (folder / "fleet.yaml").write_text(json.dumps({"controllers": entries}))
    return folder


def test_the_drifting_controllers_rank_first_and_a_missing_file_fails_alone(fleet, capsys, tmp_path):
    argv = ["diagnose", "--fleet", str(fleet / "fleet.yaml"), "--json", str(tmp_path / "fleet.json")]
    code = main([*argv, "--quiet"])  # (--report: each controller's page as diagnose --report writes it; slow)
    out, err = capsys.readouterr()
    assert code == 2 and err.strip().splitlines() == [
        f"pmr-ros: error: --fleet {fleet / 'fleet.yaml'}: 1 of 4 controllers failed: C4"
    ]
    summary = json.loads((tmp_path / "fleet.json").read_text())["summary"]
    top = [(row["controller"], row["element"], row["verdict"]) for row in summary[:2]]
    assert sorted(top) == [("C2", "G11", "mismatch"), ("C3", "G21", "mismatch")], summary[:4]
    assert [row["rank"] for row in summary] == list(range(1, len(summary) + 1))
    others = [row for row in summary[2:] if row["controller"] != "C4"]
    assert len(others) == 10 and all(row["verdict"] in ("ok", "inconclusive") for row in others)
    failed = summary[-1]
    assert failed["controller"] == "C4" and failed["verdict"] == "failed" and "C4.csv: no such file" in failed["reason"]
    # the -25 % gain of G21 does more to control than the +18 % of G11 (which even tracks a little better): it leads
    assert summary[0]["controller"] == "C3" and summary[0]["ise_ratio"] > 1.0 > summary[1]["ise_ratio"] * 0.9
    # the index page links every controller that ran, in the summary's order; the failed one says why
    index = index_page(
        [row | {"report": row["controller"]} if row["verdict"] != "failed" else row for row in summary], 4
    )
    assert index.index("C3/index.html") < index.index("C2/index.html") < index.index("C1/index.html")
    assert "no such file" in index and "C4/index.html" not in index and index.count('class="mismatch"') == 2
    assert out.splitlines()[1].split()[:4] == ["1", "C3", "G21", "mismatch"]


def test_fleet_files_are_checked_in_one_line(tmp_path):
    (tmp_path / "a.yaml").write_text("controllers:\n  - {name: A, params: p.yaml}\n")
    with pytest.raises(ServiceError, match=r"controllers\[0\]: no data"):
        read_fleet(tmp_path / "a.yaml")
    (tmp_path / "b.yaml").write_text(
        "controllers:\n  - {name: A, params: p, data: d}\n  - {name: A, params: p, data: e}\n"
    )
    with pytest.raises(ServiceError, match="controller 'A' is listed twice"):
        read_fleet(tmp_path / "b.yaml")
    with pytest.raises(ServiceError, match="cannot read"):
        read_fleet(tmp_path / "none.yaml")
    (tmp_path / "c.yaml").write_text("window: 7d\ncontrollers:\n  - {name: A, params: p.yaml, data: d.csv, step: 1d}\n")
    (entry,) = read_fleet(tmp_path / "c.yaml")
    assert (entry.window, entry.step, entry.data) == ("7d", "1d", tmp_path / "d.csv")


def test_rank_rows_orders_impact_then_size_then_the_rest():
    rows = [
        {"verdict": "ok", "ise_ratio": None, "size_over_tolerance": 0.0},
        {"verdict": "mismatch", "ise_ratio": None, "size_over_tolerance": 4.0},
        {"verdict": "failed", "ise_ratio": None, "size_over_tolerance": None},
        {"verdict": "mismatch", "ise_ratio": 1.2, "size_over_tolerance": 2.0},
        {"verdict": "mismatch", "ise_ratio": 3.0, "size_over_tolerance": 1.0},
        {"verdict": "inconclusive", "ise_ratio": None, "size_over_tolerance": 0.0},
        {"verdict": "mismatch", "ise_ratio": None, "size_over_tolerance": 9.0},
    ]
    ranked = rank_rows(rows)
    assert [(r["verdict"], r["ise_ratio"], r["size_over_tolerance"]) for r in ranked] == [
        ("mismatch", 3.0, 1.0), ("mismatch", 1.2, 2.0), ("mismatch", None, 9.0), ("mismatch", None, 4.0),
        ("inconclusive", None, 0.0), ("ok", None, 0.0), ("failed", None, None),
    ]  # fmt: skip
    assert [r["rank"] for r in ranked] == list(range(1, 8))
