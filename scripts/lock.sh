#!/usr/bin/env bash
# Refresh requirements/test.lock to the newest releases that pyproject's ranges allow,
# then run the whole suite on the refreshed set. Commit the lock only if it passes.
# Usage: bash scripts/lock.sh [pytest args...]
set -euo pipefail
cd "$(dirname "$0")/.."
python3 -m pip install -q 'uv>=0.5'
# --universal: one lock with environment markers for every platform and Python >= 3.11
# (a Pi's aarch64 as well as a laptop's x86_64)
python3 -m uv pip compile pyproject.toml --extra test --universal --python-version 3.11 \
  --upgrade --no-header --quiet -o requirements/test.lock
git --no-pager diff --stat -- requirements/test.lock || true
exec bash scripts/test.sh "$@"
