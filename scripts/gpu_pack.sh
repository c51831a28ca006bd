#!/usr/bin/env bash
# Packs what scripts/gpu_check.sh needs on a GPU machine that cannot reach PyPI and already has
# a Python 3.12 with numpy, scipy, matplotlib and Pillow (an NVIDIA H200 machine's, say), in
# what such a machine's transfer takes (64 MiB with the checkout):
#   .labpkg/site.tar.xz        the project's other packages at constraints.txt's versions, for
#                              that Python (numba, llvmlite, moderngl, glcontext, PyGLM, trimesh,
#                              flip-evaluator), their tests left out, xz'd (~51 MB)
#   .labpkg/spirv-bins.tar.xz  glslangValidator and spirv-dis (the cost model's counts)
#   .gl/*.deb                  the EGL loader (libglvnd's packages)
# Then, there: `bash scripts/gpu_check.sh DIR` with .labpkg and .gl carried (it unpacks them).
#
#   bash scripts/gpu_pack.sh [PYTHON_VERSION]      (default 3.12; a few minutes: xz -9)
set -euo pipefail
cd "$(dirname "$0")/.."
pyver="${1:-3.12}"
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
pins=$(grep -iE "^(moderngl|glcontext|pyglm|trimesh|flip-evaluator|numba|llvmlite)==" constraints.txt)
python3 -m pip download -q --no-deps --only-binary=:all: --python-version "$pyver" \
    --implementation cp --platform manylinux_2_28_x86_64 --platform manylinux_2_27_x86_64 \
    --platform manylinux_2_17_x86_64 --platform manylinux2014_x86_64 --platform manylinux1_x86_64 \
    -d "$work/whl" $pins
mkdir -p "$work/site" .labpkg .gl
for w in "$work"/whl/*.whl; do python3 -m zipfile -e "$w" "$work/site"; done
rm -rf "$work"/site/numba/tests "$work"/site/llvmlite/tests "$work"/site/pyglm-stubs
echo "gpu_pack: compressing the site (xz -9, a few minutes)" >&2
tar -cf - -C "$work/site" . | xz -9e -T1 > .labpkg/site.tar.xz
(cd "$work" && apt-get download -q glslang-tools spirv-tools >/dev/null 2>&1)
for f in "$work"/glslang-tools_*.deb "$work"/spirv-tools_*.deb; do dpkg -x "$f" "$work/bins"; done
tar -cJf .labpkg/spirv-bins.tar.xz -C "$work/bins" usr/bin/glslangValidator usr/bin/spirv-dis
(cd .gl && apt-get download -q libegl1 libglvnd0 libopengl0 libgl1 libglx0 libgles2 >/dev/null 2>&1)
du -ch .labpkg/* .gl | tail -1 | sed 's/^/gpu_pack: carried, all told: /' >&2
