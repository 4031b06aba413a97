# shellcheck shell=bash
# Sourced (not run) by the install checks: claim a ROS domain id that no test or other check
# holds meanwhile and export it with localhost-only discovery, so a check's nodes cannot
# hear, or be heard by, anything else on the machine.  The claim is a lock on the same
# folder test/ros_fixtures.py uses, held by an open file descriptor until the shell exits.
# The tests draw ids 120..199; the checks draw 200..231 (Fast DDS ports stay valid to 232).
_pmr_ros_domain_dir="${TMPDIR:-/tmp}/pmr_ros_test_domains"
mkdir -p "$_pmr_ros_domain_dir"
ROS_DOMAIN_ID=""
for _pmr_ros_id in $(seq 200 231); do
  exec {PMR_ROS_DOMAIN_FD}>"$_pmr_ros_domain_dir/$_pmr_ros_id.lock"
  if flock -n "$PMR_ROS_DOMAIN_FD"; then
    ROS_DOMAIN_ID="$_pmr_ros_id"
    break
  fi
  exec {PMR_ROS_DOMAIN_FD}>&-
done
if [ -z "$ROS_DOMAIN_ID" ]; then
  echo "claim_ros_domain: every ROS domain id 200..231 is held by another check" >&2
  exit 1
fi
export ROS_DOMAIN_ID ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST
unset _pmr_ros_domain_dir _pmr_ros_id
