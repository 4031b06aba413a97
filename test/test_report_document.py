"""The JSON report's text: indented, a monitor's windows one to a line, and the same values as json writes."""

from __future__ import annotations

import json

from pmr_ros.report import write_json
from pmr_ros.report.document import report_text


def _report(windows: int) -> dict:
    return {
        "tool": "pmr_ros",
        "elements": {"G11": {"verdict": "mismatch", "gain": [1.5, None], "note": 'τ \u0000 "quoted"'}},
        "monitor": {"window": "14d", "windows": windows},
        "windows": [
            {"window": k, "start": f"2025-01-{k + 1:02d}", "elements": {"G11": {"gain": 0.1 * k, "ok": k % 2 == 0}}}
            for k in range(windows)
        ],
    }


def test_report_text_puts_each_window_on_its_own_line_and_reads_back_equal():
    report = _report(3)
    text = report_text(report)
    assert json.loads(text) == report
    lines = text.splitlines()
    window_lines = [line for line in lines if line.lstrip().startswith('{"window"')]
    assert len(window_lines) == 3
    assert [json.loads(line.strip().rstrip(",")) for line in window_lines] == report["windows"]
    assert lines[0] == "{" and '  "tool": "pmr_ros",' in lines  # the rest indented as json.dumps(indent=2)
    assert "τ" in text  # not escaped to ASCII


def test_report_text_without_windows_is_json_indented():
    for report in ({**_report(0)}, {key: value for key, value in _report(2).items() if key != "windows"}):
        assert report_text(report) == json.dumps(report, indent=2, ensure_ascii=False)


def test_write_json_writes_the_text_with_a_final_newline(tmp_path):
    report = _report(2)
    write_json(report, tmp_path / "report.json")
    written = (tmp_path / "report.json").read_text(encoding="utf-8")
    assert written == report_text(report) + "\n"
    assert json.loads(written) == report
