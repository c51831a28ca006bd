#!/usr/bin/env bash
# The test command: set-up, then the whole suite (headless EGL, llvmpipe on CPU machines) on
# every core: pytest-xdist, one worker a core, each worker its own process with its own EGL
# context (tests/conftest.py: workers, their caches, the tests that share one worker).
# Arguments go to pytest: `bash scripts/test.sh tests/app/test_capture.py -x`; only single
# tests (`path::name`) run in one process, and `-n 0` forces one (LAB_TEST_JOBS=N: N workers).
set -euo pipefail
cd "$(dirname "$0")/.."
LAB_WITH_XVFB=1 source scripts/setup.sh
exec .venv/bin/python -m pytest -q -n auto --dist loadgroup "$@"
