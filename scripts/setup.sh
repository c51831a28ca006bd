#!/usr/bin/env bash
# Idempotent set-up for a fresh Debian machine: Mesa's EGL/llvmpipe system packages, a C
# compiler (gcc, for app/bench/c_reference) and glslang + spirv-tools (the cost model's
# instruction counts) (apt-get when root, else one line saying what to install), a
# virtualenv in .venv, the project and its test extra at the tested versions of
# constraints.txt (refreshed by scripts/lock.sh).
# Sourced by scripts/main.sh and scripts/test.sh.  LAB_WITH_XVFB=1 (scripts/test.sh) adds
# what only the tests use: Xvfb (the window under an X server).
# .venv is reinstalled when pyproject.toml or constraints.txt changes (their hash: the stamp).
#
# Sourced into an interactive shell (`source scripts/setup.sh`), the strict options below
# are this script's own: the shell's options are restored when it returns, and a failure
# returns 1 instead of closing the shell.
if [ "${BASH_SOURCE[0]}" != "$0" ]; then
    _lab_setup_options="$(set +o)"      # a command substitution reports errexit off: from $-
    case $- in *e*) _lab_setup_options+="; set -e" ;; *) _lab_setup_options+="; set +e" ;; esac
    trap 'eval "$_lab_setup_options"; unset _lab_setup_options; trap - RETURN' RETURN
fi
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."

missing=()
have_lib() { ldconfig -p 2>/dev/null | grep -q "$1"; }
have_lib 'libEGL.so.1 ' || missing+=(libegl1)
have_lib 'libEGL_mesa.so.0' || missing+=(libegl-mesa0)
have_lib 'libGL.so.1 ' || missing+=(libgl1)
[ -n "$(ls /usr/lib/*/dri/swrast_dri.so /usr/lib/dri/swrast_dri.so 2>/dev/null)" ] || missing+=(libgl1-mesa-dri)
python3 -c 'import ensurepip' >/dev/null 2>&1 || missing+=(python3-venv)
command -v cc >/dev/null || missing+=(gcc)        # bench cpu --c-reference, its test
# the GPU cost model counts instructions from the shaders' SPIR-V (app/model/counts.py)
command -v glslangValidator >/dev/null || missing+=(glslang-tools)
command -v spirv-dis >/dev/null || missing+=(spirv-tools)
if [ "${LAB_WITH_XVFB:-0}" = 1 ]; then
    command -v Xvfb >/dev/null || missing+=(xvfb)
fi

if [ ${#missing[@]} -gt 0 ]; then
    if [ "$(id -u)" = 0 ] && command -v apt-get >/dev/null; then
        echo "setup: installing ${missing[*]}" >&2
        export DEBIAN_FRONTEND=noninteractive
        apt-get update -qq >/dev/null && apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
    else
        echo "error: missing system packages; run: sudo apt-get install ${missing[*]}" >&2
        return 1 2>/dev/null || exit 1
    fi
fi

stamp=.venv/.setup-stamp
want="$(cat pyproject.toml constraints.txt | sha256sum | cut -d' ' -f1)"
if [ ! -x .venv/bin/python ] || [ "$(cat "$stamp" 2>/dev/null)" != "$want" ]; then
    echo "setup: creating .venv and installing the project (first run takes a minute)" >&2
    python3 -m venv .venv
    if ! { .venv/bin/python -m pip install -q -c constraints.txt --upgrade pip &&
           .venv/bin/python -m pip install -q -c constraints.txt -e '.[test]'; } > .venv/pip.log 2>&1; then
        tail -n 20 .venv/pip.log >&2
        echo "error: pip install failed (full log: .venv/pip.log)" >&2
        return 1 2>/dev/null || exit 1
    fi
    echo "$want" > "$stamp"
fi
