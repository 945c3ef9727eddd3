# Source this file to get the project's environment in a shell: the venv, the colcon workspace
# (sat_msgs, sat_agent, sat_world_sim) and the packages' executables on PATH.
# Usage: source scripts/env.sh   (after `make test` or `make run` has built everything once)
_sat_root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
# shellcheck source=/dev/null
source "$_sat_root/.venv/bin/activate"
export AMENT_PREFIX_PATH="$_sat_root/.venv${AMENT_PREFIX_PATH:+:$AMENT_PREFIX_PATH}"
# shellcheck source=/dev/null
source "$_sat_root/install/setup.bash"
# The packages' executables (what `ros2 run <pkg> <exe>` finds), so `swarm`, `replay`, ... work.
export PATH="$_sat_root/install/sat_world_sim/lib/sat_world_sim:$_sat_root/install/sat_agent/lib/sat_agent:$PATH"
export RMW_IMPLEMENTATION="${RMW_IMPLEMENTATION:-rmw_fastrtps_cpp}"
unset _sat_root
