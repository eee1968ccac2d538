# Two commands set everything up: `make demo` and `make test`.
PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed

.PHONY: demo test lint docs bench clean tools mutate

# Debian packages the tests use: mbpoll, an independent Modbus client (libmodbus), gcc (the
# generated C header is compiled), chromium, the browser the mpc monitor test drives
# (playwright, pointed at /usr/bin/chromium), and Node.js with npm (the editor tests).
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

# Two workers: most tests wait on subprocesses and sockets, and the machines have two cores.
test: $(STAMP) tools lint
	$(BIN)/python -m pytest -n 2

# The VS Code extension's node packages (grammar tester, language client), from its lock file:
# installed when missing or older than package-lock.json.
VSCODE_EXT := editors/vscode

# Each program: found on PATH, or installed with apt-get (after one `apt-get update` if the
# first try fails), or `make tools` stops with a message and a non-zero exit: never a test
# suite that runs on without it.
define ensure
	@command -v $(1) >/dev/null 2>&1 || $(SUDO) apt-get install -y -q $(2) >/dev/null 2>&1 \
	  || { $(SUDO) apt-get update -q >/dev/null 2>&1 && $(SUDO) apt-get install -y -q $(2) >/dev/null; } \
	  || { echo "make tools: could not install $(2) (apt-get install $(2)) for $(3)" >&2; exit 1; }
	@command -v $(1) >/dev/null 2>&1 \
	  || { echo "make tools: $(2) is installed but there is no $(1) on PATH" >&2; exit 1; }
endef

tools:
	$(call ensure,mbpoll,mbpoll,the Modbus tests)
	$(call ensure,gcc,gcc,the C header test)
	$(call ensure,chromium,chromium,the mpc monitor browser test)
	$(call ensure,npm,nodejs npm,the editor tests)
	@[ $(VSCODE_EXT)/node_modules/.package-lock.json -nt $(VSCODE_EXT)/package-lock.json ] \
	  || npm ci --prefix $(VSCODE_EXT) --no-audit --no-fund --loglevel=error >/dev/null \
	  || { echo "make tools: npm ci in $(VSCODE_EXT) failed; the editor tests need it" >&2; exit 1; }

# Mutation testing (docs/testing.md): mutmut over the modules that guard correctness, each
# group against its own tests, cached in build/mutation/ so a second run only redoes what
# changed. Not part of `make test`. `make mutate GROUPS="manifest encoder"` runs some groups.
mutate: $(STAMP)
	$(BIN)/python -m mplang.tools.mutate $(GROUPS)

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
	$(BIN)/python bench/lsp.py
	$(BIN)/python bench/interp.py
	$(BIN)/python bench/modbus.py
	$(BIN)/python bench/flash.py
	$(BIN)/python bench/soak.py

clean:
	rm -rf $(VENV) build *.egg-info
