# emla: the suite's entry points. `make help` lists them.
VENV := .venv
EMLA := $(VENV)/bin/emla

.PHONY: help setup test demo bench clean

help:
	@echo "make setup  - create .venv/ with ROS 2 Jazzy wheels, emla_msgs and the emla packages (idempotent)"
	@echo "make test   - run the test suite (sets up first)"
	@echo "make demo   - run the default scenario end to end (sets up first)"
	@echo "make bench  - measure the hot paths; writes bench-results.json (sets up first)"
	@echo "make clean  - remove .venv/ and build outputs"

setup:
	@bash scripts/setup.sh

test: setup
	$(VENV)/bin/python -m pytest tests

demo: setup
	bash scripts/demo.sh

bench: setup
	$(VENV)/bin/python -m benchmarks

clean:
	rm -rf $(VENV) build install log emla_*/build emla_*/*.egg-info
