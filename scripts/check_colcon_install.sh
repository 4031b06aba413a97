#!/usr/bin/env bash
# Check that pmr_ros works as a ROS 2 package built by colcon, installed by copy (not
# --symlink-install, so the source tree cannot stand in for what was installed):
#   1. colcon build in a throwaway workspace (mktemp) with the working tree under src/;
#   2. source its install/setup.bash and ask the ament index for the package prefix, as
#      `ros2 run` does; pmr_ros must import from that prefix and find its data there;
#   3. start <prefix>/lib/pmr_ros/pmr_diagnostician --ros-args --params-file
#      <prefix>/share/pmr_ros/config/wood_berry.yaml, wait for its first report on
#      /diagnostics (scripts/probe_diagnostics.py), SIGINT it: exit code 0, no traceback,
#      no ERROR/FATAL log line.
# With --test it also runs `colcon test` there (the whole suite again: about 10 minutes).
# colcon (colcon-common-extensions from PyPI) goes into the project venv: colcon builds
# with the interpreter it runs on, which must be the one with rclpy, and that interpreter
# becomes the installed nodes' shebang.
#   usage: scripts/check_colcon_install.sh [--test] [--keep]   (PMR_ROS_VENV: the venv)
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
VENV="${PMR_ROS_VENV:-$ROOT/.venv}"
RUN_TESTS=0
KEEP=0
for arg in "$@"; do
  case "$arg" in
    --test) RUN_TESTS=1 ;;
    --keep) KEEP=1 ;;
    *) echo "usage: $0 [--test] [--keep]" >&2; exit 2 ;;
  esac
done

say() { echo "check_colcon_install: $*"; }
fail() { echo "check_colcon_install: FAILED: $*" >&2; exit 1; }
now() { date +%s.%N; }
took() { awk -v a="$1" -v b="$(now)" 'BEGIN { printf "%.1f s", b - a }'; }

"$ROOT/scripts/bootstrap.sh"
if ! "$VENV/bin/python" -c "import colcon_core" 2> /dev/null; then
  say "installing colcon-common-extensions into $VENV"
  "$VENV/bin/python" -m pip install -q "colcon-common-extensions>=0.3,<0.4"
fi

WS="$(mktemp -d "${TMPDIR:-/tmp}/pmr_ros_colcon.XXXXXX")"
NODE_PID=""
cleanup() {
  if [ -n "$NODE_PID" ] && kill -0 "$NODE_PID" 2> /dev/null; then kill -KILL "$NODE_PID" 2> /dev/null || true; fi
  if [ "$KEEP" = 1 ]; then say "workspace kept: $WS"; else rm -rf "$WS"; fi
}
trap cleanup EXIT
"$ROOT/scripts/export_tree.sh" "$WS/src/pmr_ros"

# 1. Build.  Logs go to the workspace; shown only when something fails.
start="$(now)"
if ! (cd "$WS" && "$VENV/bin/colcon" build --event-handlers console_cohesion+ > "$WS/build.log" 2>&1); then
  cat "$WS/build.log" >&2
  fail "colcon build"
fi
say "colcon build took $(took "$start")"

# 2. The environment `ros2 run` would have.  Only this workspace: whatever was sourced before
# goes (rclpy and the messages come from the venv's wheels, which need no sourcing).
unset AMENT_PREFIX_PATH PYTHONPATH COLCON_PREFIX_PATH
set +u # colcon's setup scripts read variables that may be unset
# shellcheck source=/dev/null
source "$WS/install/setup.bash"
set -u
PREFIX="$("$VENV/bin/python" -c 'from ament_index_python.packages import get_package_prefix; print(get_package_prefix("pmr_ros"))')" \
  || fail "the ament index of $WS/install has no pmr_ros"
[ "$PREFIX" = "$WS/install/pmr_ros" ] || fail "ament index gives $PREFIX, not the workspace's $WS/install/pmr_ros"
# From a directory outside the source tree: the installed copy must be the one imported and
# must find its data under the prefix (the lookup once ignored the ament index).
WHERE="$(cd "$WS" && "$VENV/bin/python" -c '
import pmr_ros
from pmr_ros.resources import share_dir
print(pmr_ros.__file__)
print(share_dir("config", "wood_berry.yaml"))
print(share_dir("msg_defs", "topics.yaml"))
print(pmr_ros.__version__)')" || fail "import pmr_ros from the workspace"
while IFS= read -r line; do
  case "$line" in
    "$PREFIX"/*) ;;
    /*) fail "$line is not under the install prefix $PREFIX" ;;
  esac
done <<< "$WHERE"
VERSION="$(sed -n 's:.*<version>\(.*\)</version>.*:\1:p' "$ROOT/package.xml")"
[ "$(tail -n 1 <<< "$WHERE")" = "$VERSION" ] || fail "installed pmr_ros.__version__ $(tail -n 1 <<< "$WHERE") is not package.xml's $VERSION"
say "ament prefix $PREFIX; pmr_ros $VERSION imports and finds config/ and msg_defs/ there"
# Every console script of setup.py is installed where `ros2 run pmr_ros <name>` looks for it.
# shellcheck source=scripts/check_executables.sh
source "$ROOT/scripts/check_executables.sh"
check_executables "$PREFIX/lib/pmr_ros"

# 3. One node, as `ros2 run pmr_ros pmr_diagnostician --ros-args --params-file ...` starts it.
# shellcheck source=scripts/claim_ros_domain.sh
source "$ROOT/scripts/claim_ros_domain.sh"
NODE_LOG="$WS/pmr_diagnostician.log"
start="$(now)"
(cd "$WS" && exec "$PREFIX/lib/pmr_ros/pmr_diagnostician" --ros-args --params-file "$PREFIX/share/pmr_ros/config/wood_berry.yaml") > "$NODE_LOG" 2>&1 &
NODE_PID=$!
if ! REPORT="$("$VENV/bin/python" "$ROOT/scripts/probe_diagnostics.py" --prefix pmr/wood_berry/ --timeout 60)"; then
  cat "$NODE_LOG" >&2
  fail "pmr_diagnostician (domain $ROS_DOMAIN_ID) did not report on /diagnostics"
fi
kill -0 "$NODE_PID" 2> /dev/null || { cat "$NODE_LOG" >&2; fail "pmr_diagnostician exited early"; }
say "pmr_diagnostician reported after $(took "$start") (domain $ROS_DOMAIN_ID): $REPORT"
start="$(now)"
kill -INT "$NODE_PID"
for _ in $(seq 1 150); do kill -0 "$NODE_PID" 2> /dev/null || break; sleep 0.1; done
if kill -0 "$NODE_PID" 2> /dev/null; then
  cat "$NODE_LOG" >&2
  fail "pmr_diagnostician still running 15 s after SIGINT"
fi
status=0
wait "$NODE_PID" || status=$?
NODE_PID=""
if [ "$status" -ne 0 ] || grep -qE 'Traceback|\[(ERROR|FATAL)\]' "$NODE_LOG"; then
  cat "$NODE_LOG" >&2
  fail "pmr_diagnostician stopped with exit code $status or logged an error"
fi
say "pmr_diagnostician stopped on SIGINT in $(took "$start"), exit code 0, no error output"

# 4. Optional: the test suite as colcon runs it in the workspace.
if [ "$RUN_TESTS" = 1 ]; then
  start="$(now)"
  test_status=0
  (cd "$WS" && "$VENV/bin/colcon" test --event-handlers console_cohesion+ --pytest-args -q) > "$WS/test.log" 2>&1 || test_status=$?
  tail -n 40 "$WS/test.log"
  (cd "$WS" && "$VENV/bin/colcon" test-result --all) || test_status=1
  say "colcon test took $(took "$start")"
  [ "$test_status" -eq 0 ] || fail "colcon test"
fi
say "OK"
