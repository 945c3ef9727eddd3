#!/usr/bin/env bash
# Run one command inside the project's environment (see env.sh): scripts/with_env.sh CMD ARGS...
set -eo pipefail
# Not `set -u`: colcon's generated setup.bash reads unset variables.
# shellcheck source=/dev/null
source "$(dirname "${BASH_SOURCE[0]}")/env.sh"
exec "$@"
