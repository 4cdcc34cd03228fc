# The two commands of the README, each bootstrapping itself (tools/bootstrap.sh is idempotent).
#   make demo   the bridge on a python-can virtual bus with simulated drives
#   make test   the whole test suite
VENV ?= .venv
export DRIVE_BRIDGE_VENV := $(abspath $(VENV))
# DDS stays on this machine's loopback unless the caller chose otherwise.
export ROS_AUTOMATIC_DISCOVERY_RANGE ?= LOCALHOST

.PHONY: bootstrap demo test bench

bootstrap:
	@tools/bootstrap.sh

demo: bootstrap
	$(VENV)/bin/bridge $(ARGS)

test: bootstrap
	$(VENV)/bin/python -m pytest $(ARGS)

bench: bootstrap
	$(VENV)/bin/python -m bench $(ARGS)
