#!/usr/bin/env bash
# Set up (first time), lint and check formatting with ruff, type-check with mypy and run the test suite.
# Each step must pass.  Extra arguments go to pytest.  The suite runs on every core
# (pytest-xdist; PMR_ROS_TEST_WORKERS=0 runs it in this process, e.g. for a debugger).
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
"$ROOT/scripts/bootstrap.sh"
VENV="${PMR_ROS_VENV:-$ROOT/.venv}"
cd "$ROOT"
"$VENV/bin/ruff" check pmr_ros test benchmarks
"$VENV/bin/ruff" format --check pmr_ros test benchmarks
"$VENV/bin/mypy" pmr_ros
exec "$VENV/bin/python" -m pytest -n "${PMR_ROS_TEST_WORKERS:-auto}" --dist worksteal "$@"
