#!/usr/bin/env bash
# The four node processes under two busy loops, five runs in a row (issue 21, item 11):
# prints per run whether the verdicts covered the full window, and the wall time.
#   usage: scripts/load_check.sh [--runs 5] [--samples 8192] [--busy 2] [--log-dir DIR]
# Runs in a ROS domain of its own (scripts/claim_ros_domain.sh) with the Python of $PYTHON
# (default: .venv/bin/python of this checkout, else python3) and this checkout's pmr_ros.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$root"
# shellcheck source=scripts/claim_ros_domain.sh
source scripts/claim_ros_domain.sh
python="${PYTHON:-}"
if [ -z "$python" ]; then
  if [ -x .venv/bin/python ]; then python=.venv/bin/python; else python=python3; fi
fi
PYTHONPATH="$root${PYTHONPATH:+:$PYTHONPATH}" exec "$python" scripts/load_check.py "$@"
