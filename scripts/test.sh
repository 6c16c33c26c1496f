#!/usr/bin/env bash
# All tests: the C++ suite through ctest, the documentation site, then the Python suite
# through pytest.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
export PATH="$PWD/.venv/bin:$PATH"
cmake -S . -B build/ctest -G Ninja -DVPFFD_BUILD_TESTS=ON -DVPFFD_BUILD_PYTHON=OFF -DCMAKE_BUILD_TYPE=Release >/dev/null
cmake --build build/ctest -j 2
(cd build/ctest && ctest --output-on-failure -j 2)
# The installed CMake package works from another project.
echo "test: installing the CMake package and building examples/cpp against it"
cmake --install build/ctest --prefix build/install >/dev/null
cmake -S examples/cpp -B build/example -G Ninja -DCMAKE_PREFIX_PATH="$PWD/build/install" --log-level=WARNING
cmake --build build/example
build/example/squash_sphere
if [ -x build/example/gpu_frame ]; then build/example/gpu_frame; fi
if [ -x build/example/mesh_file ]; then build/example/mesh_file; fi
# The documentation site, strictly (broken links and anchors fail; offline, ~3 s).
echo "test: building the documentation site into build/site"
NO_MKDOCS_2_WARNING=1 python -m mkdocs build --strict --quiet --site-dir build/site
# The binary wheel from setup.sh's build folder (seconds); tests/python/test_wheel.py installs it.
bash scripts/build_wheel.sh
python -m pytest tests/python -q "$@"
