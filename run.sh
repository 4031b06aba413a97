#!/usr/bin/env bash
# Set up (first time) and run the main job: the Wood-Berry column under MPC with the
# paper's full mismatch, diagnosed with the PMR.  Extra arguments go to `pmr-ros run`.
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
"$ROOT/scripts/bootstrap.sh"
exec "${PMR_ROS_VENV:-$ROOT/.venv}/bin/pmr-ros" run "$@"
