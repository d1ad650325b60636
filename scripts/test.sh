#!/usr/bin/env bash
# Install everything the tests need on a fresh Debian machine, then run the whole suite.
# Usage: bash scripts/test.sh [pytest args...]
#   URC_DEPS=latest bash scripts/test.sh   the newest releases instead of the locked set
#   bash scripts/lock.sh                   refresh the lock, then run the suite on it
set -euo pipefail
cd "$(dirname "$0")/.."

# Debian packages the tests drive for real: Hamlib's own rotctl/rotctld clients, and
# Chromium for the dashboard's browser tests (Playwright drives /usr/bin/chromium; it
# never downloads a browser of its own).
# gcc, the kernel and Python headers: pip builds evdev's C extension (IR remote tests)
# from source where no wheel fits; systemd's own systemd-analyze checks urc's unit file.
# mosquitto: the MQTT tests start their own broker (never the system service); openssl
# makes their throwaway CA and certificates (mqtts://).
DEB_PACKAGES=(libhamlib-utils chromium gcc linux-libc-dev python3-dev systemd mosquitto openssl)
missing=()
for pkg in "${DEB_PACKAGES[@]}"; do
  dpkg -s "$pkg" >/dev/null 2>&1 || missing+=("$pkg")
done
# npm installs axe-core, the accessibility rules the browser tests run on every page
# (tests/web/package-lock.json); any npm will do (Debian's, or one that came with node)
command -v npm >/dev/null 2>&1 || missing+=(npm)
if [ ${#missing[@]} -gt 0 ]; then
  SUDO=""; [ "$(id -u)" -ne 0 ] && SUDO="sudo"
  $SUDO apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq "${missing[@]}"
fi

# The tests run on the exact versions in requirements/test.lock (a constraints file:
# `pip install -e .` for users keeps pyproject's ranges). URC_DEPS=latest takes the
# newest releases instead, to see what a refreshed lock would meet.
if [ "${URC_DEPS:-locked}" = latest ]; then
  python3 -m pip install -q --upgrade --upgrade-strategy eager -e '.[test]'
else
  python3 -m pip install -q -c requirements/test.lock -e '.[test]'
fi
# axe-core for the browser tests' accessibility checks (a local file, no CDN)
npm ci --prefix tests/web --no-audit --no-fund --silent
# The suite starts hundreds of interpreters (urc run, its control process, the CLI): each
# loads urc's modules from cached bytecode (__pycache__, git-ignored) instead of compiling
# ~200 of them from source, ~0.25 s of CPU per interpreter where PYTHONDONTWRITEBYTECODE
# is set
unset PYTHONDONTWRITEBYTECODE
exec python3 -m pytest "$@"
