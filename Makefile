# Two commands set everything up: `make demo` and `make test`.
PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed

.PHONY: demo test lint docs bench clean

$(STAMP): pyproject.toml
	test -x $(BIN)/python || $(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e '.[dev]'
	touch $(STAMP)

# The main job. Until the virtual controller lands (issue 3) it builds every sample into one
# image and shows the listing and the link map.
demo: $(STAMP)
	$(BIN)/mpc build samples/*.mp --format listing
	@echo
	$(BIN)/mpc build samples/*.mp --format map
	mkdir -p build
	$(BIN)/mpc build samples/*.mp -o build/samples.image.json
	@echo "image written to build/samples.image.json"

test: $(STAMP) lint
	$(BIN)/python -m pytest

lint: $(STAMP)
	$(BIN)/ruff check mplang tests bench
	$(BIN)/mypy

docs: $(STAMP)
	$(BIN)/python -m mplang.docgen

bench: $(STAMP)
	$(BIN)/python bench/compile.py

clean:
	rm -rf $(VENV) build *.egg-info
