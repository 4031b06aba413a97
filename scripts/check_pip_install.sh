#!/usr/bin/env bash
# Check that a plain, non-editable `pip install .[ros]` is complete: into a fresh venv (no
# --system-site-packages, so every dependency must be declared in setup.py), from a copy
# of the working tree (pip would otherwise leave build/ and egg-info in the checkout),
# then, from a directory outside the source tree so the checkout cannot leak in:
#   - pmr_ros imports from the venv and finds config/ and msg_defs/ in <venv>/share/pmr_ros;
#   - every pmr_ros module imports (dependencies imported at module level are declared);
#   - pmr-ros --version is package.xml's version;
#   - pmr-ros diagnose bags/wood_berry_full (the reference bag: offline verdicts compared
#     with the recorded ones; exit 4 when they differ);
#   - pmr-ros run --batch (the numpy/scipy core) and pmr-ros run (the ROS 2 node set in one
#     process, so the ros extra must be complete), 4096 samples each.
#   usage: scripts/check_pip_install.sh [--keep]   (PYTHON: the interpreter, python3 by default)
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
PY="${PYTHON:-python3}"
KEEP=0
case "${1:-}" in
  "") ;;
  --keep) KEEP=1 ;;
  *) echo "usage: $0 [--keep]" >&2; exit 2 ;;
esac

say() { echo "check_pip_install: $*"; }
fail() { echo "check_pip_install: FAILED: $*" >&2; exit 1; }
now() { date +%s.%N; }
took() { awk -v a="$1" -v b="$(now)" 'BEGIN { printf "%.1f s", b - a }'; }

WORK="$(mktemp -d "${TMPDIR:-/tmp}/pmr_ros_pip.XXXXXX")"
cleanup() { if [ "$KEEP" = 1 ]; then say "kept: $WORK"; else rm -rf "$WORK"; fi; }
trap cleanup EXIT
"$ROOT/scripts/export_tree.sh" "$WORK/src"
VENV="$WORK/venv"
OUTSIDE="$WORK/elsewhere"
mkdir "$OUTSIDE"
# Nothing inherited may add packages or data: the venv alone has to hold them.
unset PYTHONPATH AMENT_PREFIX_PATH COLCON_PREFIX_PATH

start="$(now)"
"$PY" -m venv "$VENV"
if ! "$VENV/bin/python" -m pip install -q "$WORK/src[ros]" > "$WORK/pip.log" 2>&1; then
  cat "$WORK/pip.log" >&2
  fail "pip install $WORK/src[ros]"
fi
"$VENV/bin/python" -m pip check > "$WORK/pip-check.log" 2>&1 || { cat "$WORK/pip-check.log" >&2; fail "pip check"; }
say "fresh venv + pip install .[ros] took $(took "$start")"

cd "$OUTSIDE"
WHERE="$("$VENV/bin/python" -c '
import pmr_ros
from pmr_ros.resources import share_dir
print(pmr_ros.__file__)
print(share_dir("config", "wood_berry.yaml"))
print(share_dir("msg_defs", "topics.yaml"))')" || fail "import pmr_ros from $VENV"
while IFS= read -r line; do
  case "$line" in
    "$VENV"/*) ;;
    *) fail "$line is not in the venv $VENV" ;;
  esac
done <<< "$WHERE"
VERSION="$(sed -n 's:.*<version>\(.*\)</version>.*:\1:p' "$ROOT/package.xml")"
GOT="$("$VENV/bin/pmr-ros" --version 2>&1)" || { echo "$GOT" >&2; fail "pmr-ros --version"; }
[ "$GOT" = "pmr-ros $VERSION" ] || fail "pmr-ros --version says '$GOT', package.xml $VERSION"
say "pmr_ros $VERSION imports from the venv and finds config/ and msg_defs/ in $VENV/share/pmr_ros"
# Every console script of setup.py is installed next to the venv's interpreter.
# shellcheck source=scripts/check_executables.sh
source "$ROOT/scripts/check_executables.sh"
check_executables "$VENV/bin"
# Every module imports: a dependency imported at module level but missing from setup.py fails here
# even when no command below reaches that module.
"$VENV/bin/python" -c '
import importlib, pkgutil, pmr_ros
for module in pkgutil.walk_packages(pmr_ros.__path__, "pmr_ros."):
    importlib.import_module(module.name)' > "$WORK/import.log" 2>&1 || { cat "$WORK/import.log" >&2; fail "importing every pmr_ros module"; }

# Each command's output is shown only when it fails; its exit code is the verdict.
run() {
  local label="$1"
  shift
  local t0 status=0
  t0="$(now)"
  "$VENV/bin/pmr-ros" "$@" > "$WORK/out.log" 2>&1 || status=$?
  if [ "$status" -ne 0 ] || grep -q 'Traceback' "$WORK/out.log"; then
    cat "$WORK/out.log" >&2
    fail "pmr-ros $* (exit code $status)"
  fi
  say "$label took $(took "$t0")"
}
run "pmr-ros diagnose bags/wood_berry_full" diagnose "$ROOT/bags/wood_berry_full"
run "pmr-ros run --batch --samples 4096" run --batch --samples 4096
# shellcheck source=scripts/claim_ros_domain.sh
source "$ROOT/scripts/claim_ros_domain.sh"
run "pmr-ros run --samples 4096 (ROS 2 nodes, domain $ROS_DOMAIN_ID)" run --samples 4096
say "OK"
