# The two commands of the README, each bootstrapping itself (tools/bootstrap.sh is idempotent).
#   make demo   the bridge on a python-can virtual bus with simulated drives
#   make test   the whole test suite
#   make test-fast   the core's tests without ROS, simulated drives or slow ones (under a minute)
#   make test-busy   the suite as this machine runs it: from a background shell, beside a benchmark
VENV ?= .venv
export DRIVE_BRIDGE_VENV := $(abspath $(VENV))
# DDS stays on this machine's loopback unless the caller chose otherwise.
export ROS_AUTOMATIC_DISCOVERY_RANGE ?= LOCALHOST

.PHONY: bootstrap demo test test-fast test-busy bench

bootstrap:
	@tools/bootstrap.sh

demo: bootstrap
	$(VENV)/bin/bridge $(ARGS)

test: bootstrap
	$(VENV)/bin/python -m pytest $(ARGS)

test-fast: bootstrap
	$(VENV)/bin/python -m pytest -m "not ros and not sim and not slow and not static" $(ARGS)

test-busy: bootstrap
	tools/test_busy.sh $(ARGS)

bench: bootstrap
	$(VENV)/bin/python -m bench $(ARGS)
