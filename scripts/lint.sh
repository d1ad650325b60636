#!/usr/bin/env bash
# The linter and the type checker, as CI runs them (after scripts/test.sh has installed
# the locked test dependencies, ruff and mypy among them).
set -euo pipefail
cd "$(dirname "$0")/.."
python3 -m ruff check src tests bench scripts
python3 scripts/mypy_baseline.py
# the packages' import contracts (.importlinter; every import counted, in functions and
# TYPE_CHECKING blocks too). No cache: the graph takes about a second to build.
lint-imports --no-cache
