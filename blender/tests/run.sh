#!/usr/bin/env bash
# Headless tests of the Blender add-on with the bpy wheel (Blender 5.0 as a Python 3.11
# module). Not part of scripts/test.sh: the wheel is about 1 GB. On first use this
# creates ./.venv-blender (python3.11 -m venv; pip install bpy==5.0.*, scipy, pytest).
# vpffd goes in as a wheel built from this checkout: with the project's .venv when it
# is Python 3.11 too (reusing its build folder: seconds), else with .venv-blender's own
# build tools (a full C++ build the first time).
#   bash blender/tests/run.sh [pytest args]
set -euo pipefail
cd "$(dirname "$0")/../.."
VENV=${VPFFD_BLENDER_VENV:-.venv-blender}
# Absolute from here on: the tests run from blender/tests (a relative path is the checkout's).
case $VENV in /*) ;; *) VENV=$PWD/$VENV ;; esac
PY311=${PYTHON311:-python3.11}
if [ ! -x "$VENV/bin/python" ]; then
  echo "run.sh: creating $VENV (Python 3.11, for the bpy 5.0 wheel)"
  "$PY311" -m venv "$VENV"
fi
BPY="$VENV/bin/python"
if ! "$BPY" -c "import bpy, scipy, pytest" 2>/dev/null; then
  echo "run.sh: installing bpy 5.0 (about 1 GB), scipy and pytest into $VENV"
  "$BPY" -m pip install -q "bpy==5.0.*" scipy pytest
fi
ver() { "$1" -c 'import sys; print(f"{sys.version_info[0]}.{sys.version_info[1]}")'; }
WHEELS=build/blender-wheel
rm -rf "$WHEELS"
if [ -x .venv/bin/python ] && [ "$(ver .venv/bin/python)" = "$(ver "$BPY")" ] \
   && .venv/bin/python -c "import scikit_build_core, pybind11" 2>/dev/null; then
  echo "run.sh: building the vpffd wheel with .venv (build/py-.venv)"
  .venv/bin/python -m pip wheel -q --no-build-isolation --no-deps -Cbuild-dir=build/py-.venv -w "$WHEELS" .
else
  echo "run.sh: building the vpffd wheel with $VENV (build/py-${VENV##*/})"
  "$BPY" -m pip install -q scikit-build-core pybind11 cmake ninja
  "$BPY" -m pip wheel -q --no-build-isolation --no-deps -Cbuild-dir="build/py-${VENV##*/}" -w "$WHEELS" .
fi
"$BPY" -m pip install -q --force-reinstall --no-deps "$WHEELS"/vpffd-*.whl
VPFFD_BLENDER_ZIP="$(pwd)/$(bash scripts/package_blender.sh)"
export VPFFD_BLENDER_ZIP
# Run from outside the checkout so that `import vpffd` is the installed wheel.
cd blender/tests
exec "$BPY" -m pytest -q -s -p no:cacheprovider test_addon.py "$@"
