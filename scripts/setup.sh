#!/usr/bin/env bash
# Installs what vpffd needs on Debian/Ubuntu (as root) and builds it into a
# project virtual environment. Safe to run again: it only does what is missing.
#   scripts/setup.sh            -> .venv
#   VPFFD_VENV=dir scripts/setup.sh
set -euo pipefail
cd "$(dirname "$0")/.."
VENV=${VPFFD_VENV:-.venv}

APT_PACKAGES=(
  build-essential python3-dev python3-venv
  libeigen3-dev libgtest-dev
  libopenmesh-dev
  libosd-dev  # OpenSubdiv 3.5: displaced subdivision surfaces (vpffd::subdiv)
  libembree-dev
  libvulkan-dev glslc libvulkan-volk-dev mesa-vulkan-drivers
  vulkan-validationlayers  # the tests run frames under the validation layer
)
missing=()
for p in "${APT_PACKAGES[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -gt 0 ]; then
  echo "setup: installing Debian packages: ${missing[*]}"
  SUDO=""; [ "$(id -u)" -eq 0 ] || SUDO="sudo"
  $SUDO apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
fi

if [ ! -x "$VENV/bin/python" ]; then
  echo "setup: creating $VENV"
  python3 -m venv "$VENV"
fi
PY="$VENV/bin/python"
# Python packages only when one is missing: a second run needs no network.
# mkdocs, material and mkdocstrings build the documentation site (docs/, mkdocs.yml).
if ! "$PY" -c "import numpy, scipy, pytest, pybind11, scikit_build_core, cmake, ninja, matplotlib, PIL, trimesh, mkdocs, material, mkdocstrings_handlers.python" 2>/dev/null; then
  "$PY" -m pip install -q --upgrade pip >/dev/null
  "$PY" -m pip install -q numpy scipy pytest pybind11 scikit-build-core cmake ninja matplotlib pillow trimesh mkdocs mkdocs-material "mkdocstrings[python]"
fi
# A non-isolated build reuses the build folder between runs (fast rebuilds).
echo "setup: building vpffd (C++ core, bindings)"
"$PY" -m pip install -q --no-build-isolation -Cbuild-dir="build/py-${VENV##*/}" -e .
