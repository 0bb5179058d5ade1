# splatlab: `make demo` and `make test` set themselves up on a fresh machine.
PY      ?= python3
VENV    := .venv
VPY     := $(VENV)/bin/python
STAMP   := $(VENV)/.installed
LLVM    := $(VENV)/.llvm-ok
POCL    := $(VENV)/.pocl-ok
CHROMIUM := $(VENV)/.chromium-ok
# PoCL keeps compiled kernels here; Numba its compiled loops.
export POCL_CACHE_DIR ?= $(CURDIR)/.cache/pocl
export NUMBA_CACHE_DIR ?= $(CURDIR)/.cache/numba

.PHONY: demo test test-slow regress bench doctor clean setup

setup: $(STAMP) $(LLVM) $(POCL)

$(STAMP): pyproject.toml
	test -x $(VPY) || $(PY) -m venv $(VENV)
	$(VPY) -m pip install --quiet --upgrade pip
	$(VPY) -m pip install --quiet -e '.[lab,test]'
	touch $@

# Dr.Jit's LLVM backend needs libLLVM >= 16; Debian bookworm ships 14/15 by default.
$(LLVM): $(STAMP)
	@if ! $(VPY) -m lab.llvm_check >/dev/null 2>&1; then \
	  echo "Dr.Jit cannot find LLVM >= 16: installing Debian's libllvm19"; \
	  (apt-get install -y libllvm19 || (apt-get update && apt-get install -y libllvm19)) >/dev/null; \
	fi
	$(VPY) -m lab.llvm_check
	touch $@

# PoCL 3.0's LLVM 14 cannot name CPUs newer than itself (AMD Zen 5): no kernel would build.
# runtime_cl.device.pocl_cpu then names the x86-64 level of the kernel library PoCL loads (else no-op).
$(POCL): $(STAMP)
	$(VPY) -m runtime_cl.device.pocl_cpu --patch
	touch $@

# The report-page test opens a report in Debian's headless Chromium (DevTools Protocol).
$(CHROMIUM): $(STAMP)
	@if ! command -v chromium >/dev/null 2>&1; then \
	  echo "chromium not found: installing Debian's chromium for the report-page test"; \
	  (apt-get install -y chromium || (apt-get update && apt-get install -y chromium)) >/dev/null; \
	fi
	chromium --version
	touch $@

demo: setup
	$(VENV)/bin/splatlab demo

test: setup $(CHROMIUM)
	$(VPY) -m pytest -q

test-slow: setup $(CHROMIUM)
	$(VPY) -m pytest -q -m slow

# Each committed baseline (reports/baselines/<scene>/report.json, written by
# `python -m lab.report.baseline`) against a fresh report of scenes/<scene>.toml: exit 1 on a regression.
regress: setup
	@for b in reports/baselines/*/report.json; do \
	  s=$$(basename $$(dirname $$b)); \
	  $(VENV)/bin/splatlab report scenes/$$s.toml --baseline $$b --out-dir .cache/regress/$$s || exit $$?; \
	done

bench: setup
	$(VENV)/bin/splatlab bench all

doctor: setup
	$(VENV)/bin/splatlab doctor

clean:
	rm -rf .cache reports/demo
