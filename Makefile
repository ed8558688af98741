# Set-up and the project's two commands.  `make demo` (main job) and `make test` (tests)
# each create .venv on first use and install the project with constraints.txt, which pins
# the CPU build of torch so no CUDA packages are pulled.
PYTHON ?= python3
VENV   ?= .venv
PY     := $(VENV)/bin/python
STAMP  := $(VENV)/.installed

.PHONY: setup demo test lint bench clean clean-numba docs

setup: $(STAMP)

$(STAMP): pyproject.toml constraints.txt
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --upgrade pip
	$(PY) -m pip install -c constraints.txt -e ".[plots,train,dev,bench,sweep,video,docs]"
	touch $(STAMP)

demo: $(STAMP)
	$(VENV)/bin/planar3p demo

# The documentation site (docs/, Sphinx + MyST): warnings are errors (-W, every one reported:
# --keep-going), every Python reference must resolve (-n).  Output: docs/_build/html.
SPHINX := SDL_VIDEODRIVER=dummy MPLBACKEND=Agg $(PY) -m sphinx -W --keep-going -n -q -b html \
          -d docs/_build/doctrees docs docs/_build/html

docs: $(STAMP)
	$(SPHINX)

test: $(STAMP)
	$(VENV)/bin/ruff check .
	$(SPHINX)
	SDL_VIDEODRIVER=dummy MPLBACKEND=Agg $(PY) -m pytest -q -n 2

lint: $(STAMP)
	$(VENV)/bin/ruff check .
	$(VENV)/bin/ruff format --check .

bench: $(STAMP)
	$(PY) scripts/bench_kinematics.py
	$(PY) scripts/bench_env.py

# numba's on-disk cache checks only the file of the function it compiled, not the files of the
# compiled functions that one calls: after editing a compiled module, drop every cache.
clean-numba:
	find planar3p_gym agents -name '*.nbi' -delete -o -name '*.nbc' -delete

clean: clean-numba
	rm -rf $(VENV) build *.egg-info .pytest_cache .ruff_cache
