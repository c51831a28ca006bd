#!/usr/bin/env bash
# The GPU check: on a machine with a real GPU and EGL, measure every technique (the bench's
# gpu-check preset: 1920x1080, arena and city, 8,192 and 65,536 lights, one camera-path
# frame, every frame checked against brute) with GL timer queries, and write DIR/report.md
# with the measured times against the cost model's (its section "Measured on a real GPU
# against modelled").  About 6 minutes on an H200 machine of 16 cores (most of it the CPU's
# replays and checks); commit DIR as docs/gpu-check/, the record the report cites.
#
#   bash scripts/gpu_check.sh [DIR] [bench overrides, e.g. --lights 8192]   (DIR: out/gpu-check)
#
# Set-up: scripts/setup.sh's (.venv and the project), or, on a machine that cannot reach
# PyPI, wheels carried in .whl/ (README "A real GPU" lists them) and the EGL loader's Debian
# packages in .gl/, unpacked first; or scripts/gpu_pack.sh's .labpkg/ (the packages the
# machine's own Python lacks, and the SPIR-V tools), unpacked here; or LAB_PYTHON, a Python
# that already imports the project's packages.  On a software rasterizer it stops with one line: its
# times would say nothing about a GPU (LAB_GPU_CHECK_SOFTWARE=1 runs it anyway, for a try).
set -euo pipefail
cd "$(dirname "$0")/.."
out="${1:-out/gpu-check}"
shift || true
if compgen -G ".gl/*.deb" > /dev/null; then
    for f in .gl/*.deb; do dpkg -x "$f" /; done
    ldconfig
fi
nv_egl=/usr/local/nvidia/share/glvnd/egl_vendor.d/10_nvidia.json
if [ -z "${__EGL_VENDOR_LIBRARY_FILENAMES:-}" ] && [ -f "$nv_egl" ]; then
    export __EGL_VENDOR_LIBRARY_FILENAMES="$nv_egl"
fi
if [ -f .labpkg/site.tar.xz ] && [ ! -x .venv/bin/python ]; then   # gpu_pack.sh's, for the
    # machine's own Python (a checkout with its .venv uses that instead)
    mkdir -p /tmp/lab-site
    [ -d /tmp/lab-site/numba ] || tar -xJf .labpkg/site.tar.xz -C /tmp/lab-site
    [ -f .labpkg/spirv-bins.tar.xz ] && tar -xJf .labpkg/spirv-bins.tar.xz -C /
    export PYTHONPATH="/tmp/lab-site:$PWD${PYTHONPATH:+:$PYTHONPATH}"
    py="${LAB_PYTHON:-python3}"
elif [ -n "${LAB_PYTHON:-}" ]; then
    export PYTHONPATH="$PWD${PYTHONPATH:+:$PYTHONPATH}"
    py="$LAB_PYTHON"
elif compgen -G ".whl/*.whl" > /dev/null; then
    python3 -m pip install -q --no-index --no-deps --no-compile --no-cache-dir --upgrade \
        --target /tmp/lab-site .whl/*.whl
    export PYTHONPATH="/tmp/lab-site:$PWD${PYTHONPATH:+:$PYTHONPATH}"
    py=python3
else
    source scripts/setup.sh
    py=.venv/bin/python
fi
export PYTHONUNBUFFERED=1
$py - <<'EOF'
import os, sys
from app.pipeline import gl
lim = gl.limits()
print(f"gpu_check: {lim.renderer} ({lim.version}); native wave path: {lim.native_wave or 'none'}",
      file=sys.stderr)
if lim.software and os.environ.get("LAB_GPU_CHECK_SOFTWARE") != "1":
    print(f"error: {lim.renderer} is a software rasterizer, not a GPU (EGL found no GPU driver; "
          f"LAB_GPU_CHECK_SOFTWARE=1 runs the check anyway)", file=sys.stderr)
    sys.exit(2)
EOF
$py -m app.bench --gpu-check --out "$out" "$@"
echo "gpu_check: $out/report.md (measured against modelled: its section of that name)" >&2
