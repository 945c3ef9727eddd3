# The two commands of README.md. Both set everything up on first use (scripts/setup_env.sh):
# the project's venv from PyPI, the ROS 2 wheels' CMake fix, and the colcon workspace.
.PHONY: run test setup lint bench evaluate flake-hunt clean

# Arguments for `make run` (e.g. make run RUN_ARGS="--name demo").
RUN_ARGS ?=
# Arguments for `make evaluate` (e.g. make evaluate EVAL_ARGS="--seeds 5 --out /tmp/eval").
EVAL_ARGS ?=
# Arguments for pytest in `make test` (e.g. make test PYTEST_ARGS="-k msgs").
PYTEST_ARGS ?=
# Arguments for `make flake-hunt` (e.g. make flake-hunt HUNT_ARGS="--runs 5 --load").
HUNT_ARGS ?=

run: setup
	@scripts/with_env.sh python scripts/run_paper.py $(RUN_ARGS)

test: setup
	@scripts/with_env.sh python -m pytest $(PYTEST_ARGS)

setup:
	@scripts/setup_env.sh

lint: setup
	@scripts/with_env.sh python -m flake8 src scripts tests

# The Monte Carlo study behind README's evaluation: docs/evaluation*.{csv,md,png} and the
# table in README.md.
evaluate: setup
	@scripts/with_env.sh python scripts/evaluate.py --readme README.md $(EVAL_ARGS)

# The whole suite N times back to back (optionally under load); every test that ever failed.
flake-hunt: setup
	@scripts/with_env.sh python scripts/flake_hunt.py $(HUNT_ARGS)

bench: setup
	@scripts/with_env.sh python scripts/bench_filter.py

clean:
	rm -rf build install log
