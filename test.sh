#!/usr/bin/env bash
# Set up (first time), lint with ruff and run the test suite.  Extra arguments go to pytest.
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
"$ROOT/scripts/bootstrap.sh"
VENV="${PMR_ROS_VENV:-$ROOT/.venv}"
cd "$ROOT"
"$VENV/bin/ruff" check pmr_ros test benchmarks
exec "$VENV/bin/python" -m pytest "$@"
