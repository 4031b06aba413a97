#!/usr/bin/env bash
# Create .venv and install pmr_ros with its ROS 2 Jazzy, test and plot extras.
# Re-installs only when setup.py or package.xml (the version) changes (stamp file), so
# repeated runs are quick.
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
VENV="${PMR_ROS_VENV:-$ROOT/.venv}"
PY="${PYTHON:-python3}"
if [ ! -x "$VENV/bin/python" ]; then
  echo "pmr_ros: creating $VENV" >&2
  "$PY" -m venv "$VENV"
  "$VENV/bin/python" -m pip install -q --upgrade pip >&2
fi
STAMP="$VENV/.pmr_ros-installed"
WANT="$(cat "$ROOT/setup.py" "$ROOT/package.xml" | sha256sum | cut -d' ' -f1)"
if [ ! -f "$STAMP" ] || [ "$(cat "$STAMP")" != "$WANT" ]; then
  echo "pmr_ros: installing dependencies into $VENV (about a minute the first time)" >&2
  "$VENV/bin/python" -m pip install -q -e "${ROOT}[ros,test]" >&2
  echo "$WANT" > "$STAMP"
fi
