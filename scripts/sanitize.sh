#!/usr/bin/env bash
# The C++ tests and the Python test suite under AddressSanitizer + UndefinedBehaviorSanitizer.
#   bash scripts/sanitize.sh            C++ (ctest) and Python (pytest) suites
#   bash scripts/sanitize.sh cpp        the C++ suite and the fuzz corpus replay through the C++ readers
#   bash scripts/sanitize.sh py [ARGS]  the Python suite only, ARGS passed to pytest
# Needs what scripts/setup.sh installs. The sanitized Python module lives in its own
# virtual environment (.venv-asan) and build folder, so the normal build is untouched.
set -euo pipefail
cd "$(dirname "$0")/.."
what=${1:-all}
[ $# -gt 0 ] && shift
bash scripts/setup.sh >/dev/null
export PATH="$PWD/.venv/bin:$PATH"
SAN=address,undefined
# Leaks are checked in the C++ suite; UB and memory errors abort at once everywhere.
export UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1
export ASAN_OPTIONS=detect_leaks=1:abort_on_error=0:strict_string_checks=1:detect_stack_use_after_return=1

if [ "$what" = all ] || [ "$what" = cpp ]; then
  echo "sanitize: C++ suite (ASan + UBSan)"
  cmake -S . -B build/asan -G Ninja -DVPFFD_BUILD_TESTS=ON -DVPFFD_BUILD_PYTHON=OFF -DVPFFD_INSTALL=OFF \
    -DCMAKE_BUILD_TYPE=RelWithDebInfo -DVPFFD_SANITIZE=$SAN >/dev/null
  cmake --build build/asan -j 2
  # Leaks inside OpenMesh's stream multiplexer are suppressed (tests/sanitize/lsan.supp
  # says why); the Vulkan tests run without leak checking, since Mesa's lavapipe keeps
  # JIT allocations (no symbols to suppress) past the instance's destruction.
  export LSAN_OPTIONS=suppressions=$PWD/tests/sanitize/lsan.supp:print_suppressions=0
  (cd build/asan && ctest --output-on-failure -j 2 -E Vulkan)
  (cd build/asan && ASAN_OPTIONS=${ASAN_OPTIONS/detect_leaks=1/detect_leaks=0} ctest --output-on-failure -j 2 -R Vulkan)
  # The fuzzer's mutants of every mesh format through the C++ readers, sanitized.
  echo "sanitize: fuzz corpus through the C++ readers (${VPFFD_FUZZ_PER_KIND:-2000} per format)"
  rm -rf build/asan/fuzz-corpus
  .venv/bin/python tests/fuzz/fuzz_io.py --write-only build/asan/fuzz-corpus --seed 7 \
    --per-kind "${VPFFD_FUZZ_PER_KIND:-2000}"
  build/asan/tests/vpffd_fuzz_replay build/asan/fuzz-corpus
fi

if [ "$what" = all ] || [ "$what" = py ]; then
  echo "sanitize: Python suite against a sanitized _core (.venv-asan)"
  VENV=.venv-asan
  [ -x $VENV/bin/python ] || python3 -m venv $VENV
  if ! $VENV/bin/python -c "import numpy, scipy, pytest, pybind11, scikit_build_core, PIL, matplotlib" 2>/dev/null; then
    $VENV/bin/python -m pip install -q numpy scipy pytest pybind11 scikit-build-core cmake ninja matplotlib pillow
  fi
  $VENV/bin/python -m pip install -q --no-build-isolation -Cbuild-dir=build/py-asan \
    -Ccmake.build-type=RelWithDebInfo -Ccmake.define.VPFFD_SANITIZE=$SAN -e .
  # The interpreter is not sanitized: the runtime must be loaded first, and the
  # interpreter's own allocations at exit are not ours to report.
  export LD_PRELOAD="$(gcc -print-file-name=libasan.so) $(gcc -print-file-name=libubsan.so)"
  ASAN_OPTIONS=detect_leaks=0:abort_on_error=0:detect_stack_use_after_return=0 \
    $VENV/bin/python -m pytest tests/python -q -p no:cacheprovider "$@"
fi
