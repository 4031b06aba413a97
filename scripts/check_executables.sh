# shellcheck shell=bash
# Sourced (not run) by the install checks, after they define say and fail:
#   check_executables DIR   every console script of setup.py is an executable file in DIR
check_executables() {
  local dir="$1" exe executables
  executables="$(sed -n 's/^ *"\([A-Za-z_-]*\) = pmr_ros\.entry:.*/\1/p' "$ROOT/setup.py")"
  [ -n "$executables" ] || fail "no console_scripts found in $ROOT/setup.py"
  for exe in $executables; do
    [ -x "$dir/$exe" ] || fail "$dir/$exe is not installed"
  done
  say "executables in $dir: ${executables//$'\n'/ }"
}
