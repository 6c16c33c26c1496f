#!/usr/bin/env bash
# Builds vpffd on a GPU machine without internet (e.g. an H100/H200 image with Python 3.12
# with numpy, pybind11, scikit-build-core, CMake and gcc, but no Eigen, Vulkan headers,
# glslc or glvnd) from the Debian packages carried in .debs/ and .gl/ (bench/README.md
# says how to fetch them), then runs what is asked:
#
#   bash bench/gpu_machine.sh [tests] [table] [table-ff] [scaling] [motion]
#
# Results go to $OUT (default bench/results/<gpu>, named after the first discrete GPU:
# h100, h200, ...); the module is built once per machine into /tmp/vpffd-site. Table 2
# reads the meshes of $VPFFD_SHARED_MESHES.
set -euo pipefail
cd "$(dirname "$0")/.."
# The NVIDIA Vulkan driver (libGLX_nvidia) needs glvnd's dispatch libraries.
for f in .gl/*.deb; do dpkg -x "$f" /; done
mkdir -p /tmp/sys
for f in .debs/*.deb; do dpkg -x "$f" /tmp/sys; done   # Eigen, Vulkan headers, volk, glslc
ldconfig -p | grep -q libvulkan.so.1 || dpkg -x .debs/libvulkan1_*.deb /
ldconfig
export PATH=/tmp/sys/usr/bin:$PATH PYTHONUNBUFFERED=1 CMAKE_BUILD_PARALLEL_LEVEL=$(nproc)
SITE=/tmp/vpffd-site
if [ ! -f $SITE/.built ]; then
  rm -rf $SITE
  # CMAKE_PREFIX_PATH replaces the one scikit-build-core would give, so pybind11 is named.
  LD_LIBRARY_PATH=/tmp/sys/usr/lib/x86_64-linux-gnu python3 -m pip install -q --no-build-isolation --no-deps \
    --target $SITE -Cbuild-dir=/tmp/vpffd-build \
    -Ccmake.define.CMAKE_PREFIX_PATH=/tmp/sys/usr -Ccmake.define.pybind11_DIR="$(python3 -m pybind11 --cmakedir)" \
    -Ccmake.define.VPFFD_WITH_OPENMESH=OFF -Ccmake.define.VPFFD_WITH_EMBREE=OFF .
  touch $SITE/.built
fi
export PYTHONPATH=$SITE
if ! python3 -c "import vpffd; print(vpffd.vulkan_devices())" | grep -q "'discrete'"; then
  # The loader looks in /usr/share/vulkan/icd.d; some images keep the ICD elsewhere.
  export VK_DRIVER_FILES=/usr/local/nvidia/share/vulkan/icd.d/nvidia_icd.json
fi
python3 -c "import vpffd; print(vpffd.vulkan_devices())"
# One folder per machine: "NVIDIA H100 80GB HBM3" -> h100 (the model's number).
OUT=${OUT:-bench/results/$(python3 -c "
import re, vpffd
names = [d['name'] for d in vpffd.vulkan_devices() if d['type'] == 'discrete'] or ['gpu']
m = re.search(r'\b([A-Za-z]*\d{2,4}[A-Za-z]*)\b', names[0])
print((m.group(1) if m else re.sub(r'\W+', '_', names[0])).lower())")}
mkdir -p "$OUT"
export VPFFD_BENCH_MACHINE=${OUT##*/}
for what in "${@:-table}"; do
  case $what in
    tests) python3 -m pytest -q -p no:cacheprovider tests/python/test_vulkan*.py tests/python/test_multires_vulkan.py \
             tests/python/test_auto_backend.py 2>&1 | tee $OUT/gpu_tests.log | tail -5 ;;
    table) python3 bench/python/bench_gpu.py --out $OUT ;;
    table-ff) python3 bench/python/bench_gpu.py --precision float-float --out $OUT ;;
    # With the A/B of the read back: the vertices in the caller's order made on the device
    # against the device's order reordered on the host (VPFFD_VULKAN_READBACK=host).
    scaling) python3 bench/python/bench_gpu.py --scaling --max-subdiv 9 --readback-ab --out $OUT ;;
    motion) python3 bench/python/bench_motion.py --md "$OUT/motion_$VPFFD_BENCH_MACHINE.md" ;;
    *) echo "gpu_machine.sh: unknown step '$what' (tests, table, table-ff, scaling, motion)" >&2; exit 2 ;;
  esac
done
