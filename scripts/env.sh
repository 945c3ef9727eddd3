# Source this file to get the project's environment in a shell: the venv, the colcon workspace
# (sat_msgs, sat_agent, sat_world_sim) and Rerun analytics off.
# Usage: source scripts/env.sh   (after `make test` or `make run` has built everything once)
_sat_root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
# shellcheck source=/dev/null
source "$_sat_root/.venv/bin/activate"
export AMENT_PREFIX_PATH="$_sat_root/.venv${AMENT_PREFIX_PATH:+:$AMENT_PREFIX_PATH}"
# shellcheck source=/dev/null
source "$_sat_root/install/setup.bash"
export RMW_IMPLEMENTATION="${RMW_IMPLEMENTATION:-rmw_fastrtps_cpp}"
export RERUN_ANALYTICS="${RERUN_ANALYTICS:-0}"
unset _sat_root
