#!/usr/bin/env bash
# The linter and the type checker, as CI runs them (after scripts/test.sh has installed
# the locked test dependencies, ruff and mypy among them).
set -euo pipefail
cd "$(dirname "$0")/.."
python3 -m ruff check src tests bench scripts
python3 scripts/mypy_baseline.py
