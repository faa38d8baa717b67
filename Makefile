# nsp — two commands on a fresh machine: `make demo` and `make test`.
PY      ?= python3.11
VENV    ?= .venv
BIN     := $(VENV)/bin
STAMP   := $(VENV)/.installed
ARCH    := $(shell uname -m)
# The torch/torchvision pair these machines install from their own disk (no internet beyond the package registries).
ifeq ($(ARCH),x86_64)
TORCH   := torch==2.14.1 torchvision==0.29.1
else
TORCH   := torch==2.9.1 torchvision==0.24.1
endif

.PHONY: setup demo test bench clean

setup: $(STAMP)

$(STAMP): pyproject.toml
	$(PY) -m venv $(VENV)
	$(BIN)/pip install -q --upgrade pip
	$(BIN)/pip install -q $(TORCH)
	$(BIN)/pip install -q -e '.[dev,app]'
	$(BIN)/python -m nsp.engine oilpaint  # the demo's compiled kernels, once a machine (other brushes: python -m nsp.engine BRUSH)
	touch $(STAMP)

demo: setup
	rm -rf outputs/demo  # a run never writes into a dir holding another: the demo replaces its own
	$(BIN)/python -m nsp.paint hydra.run.dir=outputs/demo
	@echo "Results in outputs/demo: final.png painting.svg animation.gif strokes.json metrics.json"

# The numerics tests (-m numerics) again under the CPU kernels torch would pick on other machines.
CAPABILITIES := avx2 default

test: setup
	$(BIN)/python -m nsp.engine  # every brush's kernels (the tests draw them all), once a machine
	$(BIN)/python -m pytest -n 2
	for isa in $(CAPABILITIES); do echo "numerics with ATEN_CPU_CAPABILITY=$$isa"; \
		ATEN_CPU_CAPABILITY=$$isa $(BIN)/python -m pytest -n 2 -q -m numerics || exit 1; done

bench: setup  # quality.py and seeds.py (--base) and the reference rows (--reference) need another checkout: docs/benchmarks.md
	$(BIN)/python benchmarks/demo.py
	$(BIN)/python benchmarks/engine.py
	$(BIN)/python benchmarks/render.py
	$(BIN)/python benchmarks/threads.py
	$(BIN)/python benchmarks/transport.py
	$(BIN)/python benchmarks/training.py
	$(BIN)/python benchmarks/painter.py --photos astronaut --strokes 500  # the full grid: no options (hours on 2 cores)
	$(BIN)/python benchmarks/help.py
	$(BIN)/python benchmarks/api.py

clean:
	rm -rf $(VENV) outputs/demo .pytest_cache
