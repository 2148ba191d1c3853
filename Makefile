# Two commands from a fresh clone: `make demo` and `make test`. Each creates the
# virtualenv and installs what is missing by itself.
#
# The CPU build of torch is installed first (pinned: a light wheel, no CUDA). For a GPU,
# install the CUDA build of torch into .venv yourself before `make` (see README).

PYTHON ?= python3
VENV ?= .venv
PY := $(VENV)/bin/python
STAMP := $(VENV)/.installed
TORCH_SPEC ?= torch==2.13.0

.PHONY: demo test test-slow lint bench install clean

install: $(STAMP)

$(STAMP): pyproject.toml
	test -x $(PY) || $(PYTHON) -m venv $(VENV)
	$(PY) -c "import torch" 2>/dev/null || $(PY) -m pip install "$(TORCH_SPEC)"
	$(PY) -m pip install -e ".[dev]"
	touch $(STAMP)

# zero-shot: the shipped policy against EM and nearest frontier on `street` (real
# kiss-icp + GTSAM front end), 2 trials each, 150 m travel budget; prints the table, writes plots
demo: $(STAMP)
	$(VENV)/bin/explore-rl-eval scene=street "evaluate.policies=[learned,em,nearest]" evaluate.trials=2 \
		explore.travel_budget=150 evaluate.progress_bar=false out=out/demo

lint: $(STAMP)
	$(VENV)/bin/ruff check .

test: lint
	$(PY) -m pytest -n 2 --durations=15

test-slow: $(STAMP)
	$(PY) -c "import ray" 2>/dev/null || $(PY) -m pip install -e ".[ray]"
	$(PY) -m pytest -n 2 -m slow

bench: $(STAMP)
	$(PY) benchmarks/bench_lidar.py

clean:
	rm -rf $(VENV) out outputs multirun .pytest_cache
