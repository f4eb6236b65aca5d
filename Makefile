# The README's two commands: `make demo` and `make test`. Both bootstrap everything they need.
SHELL := /bin/bash
PYTHON ?= python3
VENV := .venv
PY := $(VENV)/bin/python
INSTALLED := $(VENV)/.installed
SYSTEM_TOOLS := gcc=gcc riscv64-unknown-elf-gcc=gcc-riscv64-unknown-elf iverilog=iverilog yosys=yosys \
	ccache=ccache /usr/include/lz4.h=liblz4-dev gdb-multiarch=gdb-multiarch \
	qemu-system-riscv32=qemu-system-misc
BUILD := build

# Python writes its compiled modules (__pycache__, git-ignored) even where the environment says
# not to: the suite starts about a thousand Python processes (nodes, hexmigrate, managers), and
# each would compile the project's sources again (a third of a CLI's start-up).
export PYTHONDONTWRITEBYTECODE :=

include firmware/firmware.mk

.PHONY: demo test lint tools modules bench clean

# A recipe that fails removes the target it began to write: a linker killed midway (a full disk,
# a file size limit) left a cut node.elf that the next make took for an up-to-date one.
.DELETE_ON_ERROR:

tools:
	@scripts/ensure-tools.sh $(SYSTEM_TOOLS)

# The install compiles the CPU's block counter (C): a change to it installs again.
$(INSTALLED): pyproject.toml firmware_sim/core/block_counter.c | tools
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip
	$(PY) -m pip install --quiet -e '.[all,dev]'
	touch $@

modules: tools $(INSTALLED)
	$(PY) -m module_sdk.build --out $(BUILD)/modules

demo: modules
	@scripts/demo.sh $(VENV) $(BUILD)/modules
	$(PY) -m patrol run --scenario two-faults --out $(BUILD)/patrol/two-faults

lint: $(INSTALLED)
	$(PY) -m ruff check .
	$(PY) -m ruff format --check .

# The suite on every core (pytest-xdist), a test file per worker: the files that share a build
# folder (the HDL simulations' per-parameter builds) or a fixture never run at once. One worker
# more than the cores: many files spend their time waiting on the processes, ptys and QEMUs
# they start, and a core would idle (on 2 cores: 6 min 19 s instead of 7 min 25 s). The tests
# that judge processes on their real-time clocks (`serial`) run alone afterwards. The firmware's
# three builds go first, side by side (docs/firmware.md).
CORES := $(shell nproc)
TEST_WORKERS := $(shell echo $$(( $(CORES) + 1 )))
test: tools $(INSTALLED) lint
	$(MAKE) --no-print-directory -j$(CORES) firmware firmware-32k firmware-host
	$(PY) -m pytest -n $(TEST_WORKERS) --dist loadfile -m "not serial"
	$(PY) -m pytest -m serial

bench: tools $(INSTALLED)
	$(PY) benchmarks/hex_codec.py
	$(PY) benchmarks/scheduler.py
	$(PY) benchmarks/migration.py
	$(PY) benchmarks/decision.py
	$(PY) benchmarks/location.py
	$(PY) benchmarks/crossbar.py
	$(PY) benchmarks/hostile.py
	$(PY) benchmarks/dehazer.py
	$(PY) benchmarks/servoing_task.py
	$(PY) benchmarks/control.py
	$(PY) benchmarks/fleet.py
	$(PY) benchmarks/firmware.py
	$(PY) benchmarks/firmware_stack.py
	$(PY) benchmarks/firmware_stack.py --capacities-32k

clean:
	rm -rf $(BUILD) .pytest_cache .ruff_cache .hypothesis
	find . -path ./.venv -prune -o -name __pycache__ -type d -exec rm -rf {} +
