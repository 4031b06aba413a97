#!/usr/bin/env bash
# Create .venv and install pmr_ros with its ROS 2 Jazzy, test and data extras, and Debian's chromium
# (the HTML report's headless-browser test; installed once, when absent).
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
  "$VENV/bin/python" -m pip install -q -e "${ROOT}[ros,test,data]" >&2
  echo "$WANT" > "$STAMP"
fi
if ! command -v chromium > /dev/null 2>&1; then
  echo "pmr_ros: installing chromium (the HTML report's browser test)" >&2
  if [ "$(id -u)" = 0 ]; then SUDO=(); else SUDO=(sudo); fi
  "${SUDO[@]}" apt-get update -qq >&2
  DEBIAN_FRONTEND=noninteractive "${SUDO[@]}" apt-get install -y -qq chromium >&2
fi
