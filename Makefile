# waamflow — the two README commands (`make run`, `make test`) plus `make bench`.
# Python 3.11+ and Node 20+ on PATH; everything else is installed into .venv/ and node_modules/.

PYTHON ?= python3
VENV   := .venv
PY     := $(VENV)/bin/python
PORT   ?= 8000
HOST   ?= 127.0.0.1
DATA   ?= data

.PHONY: run test bench soak venv frontend test-backend test-frontend test-e2e clean lint docs

$(VENV)/.installed: requirements.lock pyproject.toml
	@test -x $(PY) || $(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip
	$(PY) -m pip install --quiet -r requirements.lock
	$(PY) -m pip install --quiet --no-deps -e .
	@touch $@

venv: $(VENV)/.installed

node_modules/.installed: package.json package-lock.json frontend/package.json
	npm ci --no-audit --no-fund
	@touch $@

frontend/dist/index.html: node_modules/.installed $(shell find frontend/src frontend/index.html frontend/vite.config.ts -type f 2>/dev/null)
	npm run build

frontend: frontend/dist/index.html

run: venv frontend
	$(VENV)/bin/waamflow serve --host $(HOST) --port $(PORT) --data $(DATA)

test: venv frontend lint docs
	$(PY) -m pytest -q
	npm run test:unit
	SKIP_BUILD=1 npm run test:e2e

test-backend: venv
	$(PY) -m pytest -q

# ruff (lint rules in pyproject.toml [tool.ruff.lint]), mypy (the backend's types: [tool.mypy],
# strict on core/ and engine/), deptry (imports = declared dependencies) and eslint on the
# frontend (frontend/eslint.config.js)
lint: venv node_modules/.installed
	$(VENV)/bin/ruff check backend tests bench scripts
	$(VENV)/bin/ruff format --check backend tests bench scripts
	$(PY) scripts/check_structure.py
	$(VENV)/bin/mypy
	$(VENV)/bin/deptry backend
	npm run lint

$(VENV)/.docs-installed: requirements-docs.lock $(VENV)/.installed
	$(PY) -m pip install --quiet -r requirements-docs.lock
	@touch $@

# the documentation site: generated pages (node and REST reference, validation, bench) from the
# code, then mkdocs with --strict (a broken link or a missing page fails); site in out/site/
docs: $(VENV)/.docs-installed
	$(PY) scripts/gen_docs.py
	NO_MKDOCS_2_WARNING=1 $(VENV)/bin/mkdocs build --strict --quiet --site-dir out/site

bench: venv
	$(PY) bench/run.py

# a real server under 50 clients and the hostile inputs of issue 26 for SOAK_S seconds: RSS, p99, alive
SOAK_S ?= 60
soak: venv
	$(PY) bench/bench_soak.py $(SOAK_S) 50

clean:
	rm -rf out frontend/dist
