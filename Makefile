# Two commands set everything up: `make demo` and `make test`.
PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed

.PHONY: demo test lint docs bench clean tools

# Debian packages the tests use: mbpoll, an independent Modbus client (libmodbus), and
# chromium, the browser the mpc monitor test drives (playwright, pointed at /usr/bin/chromium).
SUDO := $(shell [ "$$(id -u)" != 0 ] && command -v sudo >/dev/null 2>&1 && echo sudo)

$(STAMP): pyproject.toml
	test -x $(BIN)/python || $(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade 'pip>=25.1'
	$(BIN)/python -m pip install --quiet -e '.[plot,lsp,monitor]' --group dev
	touch $(STAMP)

# The main job: build every sample into one image (listing, link map, image JSON), then run
# the homing-and-square job on the built-in virtual controller.
demo: $(STAMP)
	$(BIN)/mpc build samples/*.mp --format listing
	@echo
	$(BIN)/mpc build samples/*.mp --format map
	mkdir -p build
	$(BIN)/mpc build samples/*.mp -o build/samples.image.json
	@echo "image written to build/samples.image.json"
	$(BIN)/mpc run samples/home_then_square.mp --call home_then_square
	$(BIN)/mpc run samples/tour.mp --call tour --json

test: $(STAMP) tools lint
	$(BIN)/python -m pytest

# The VS Code extension's node packages (grammar tester, language client), from its lock file:
# installed when missing or older than package-lock.json.
VSCODE_EXT := editors/vscode

tools:
	@command -v mbpoll >/dev/null 2>&1 || $(SUDO) apt-get install -y -q mbpoll >/dev/null 2>&1 \
	  || { $(SUDO) apt-get update -q >/dev/null 2>&1 && $(SUDO) apt-get install -y -q mbpoll >/dev/null; } \
	  || echo "make: could not install mbpoll; the tests that use it will fail"
	@command -v npm >/dev/null 2>&1 || $(SUDO) apt-get install -y -q nodejs npm >/dev/null 2>&1 \
	  || { $(SUDO) apt-get update -q >/dev/null 2>&1 && $(SUDO) apt-get install -y -q nodejs npm >/dev/null; } \
	  || echo "make: could not install nodejs and npm; the editor tests will fail"
	@command -v chromium >/dev/null 2>&1 || $(SUDO) apt-get install -y -q chromium >/dev/null 2>&1 \
	  || { $(SUDO) apt-get update -q >/dev/null 2>&1 && $(SUDO) apt-get install -y -q chromium >/dev/null; } \
	  || echo "make: could not install chromium; the mpc monitor browser test will fail"
	@[ $(VSCODE_EXT)/node_modules/.package-lock.json -nt $(VSCODE_EXT)/package-lock.json ] \
	  || npm ci --prefix $(VSCODE_EXT) --no-audit --no-fund --loglevel=error >/dev/null \
	  || echo "make: npm ci in $(VSCODE_EXT) failed; the editor tests will fail"

# mypy twice: for this machine and as on Windows (docs/platforms.md), where pty, termios and
# the other POSIX-only modules do not exist.
lint: $(STAMP)
	$(BIN)/ruff check mplang tests bench
	$(BIN)/mypy
	$(BIN)/mypy --platform win32

docs: $(STAMP)
	$(BIN)/python -m mplang.tools.docgen
	$(BIN)/python -m mplang.tools.editors

bench: $(STAMP)
	$(BIN)/python bench/compile.py
	$(BIN)/python bench/interp.py
	$(BIN)/python bench/modbus.py
	$(BIN)/python bench/flash.py
	$(BIN)/python bench/soak.py

clean:
	rm -rf $(VENV) build *.egg-info
