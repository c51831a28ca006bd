#!/usr/bin/env bash
# The test command: set-up, then the whole suite (headless EGL, llvmpipe on CPU machines).
set -euo pipefail
cd "$(dirname "$0")/.."
LAB_WITH_XVFB=1 source scripts/setup.sh
exec .venv/bin/python -m pytest -q "$@"
