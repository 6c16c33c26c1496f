#!/usr/bin/env bash
# Packs the Blender add-on into dist/vpffd_blender-<version>.zip, a zip that both
# Preferences > Add-ons > Install (legacy) and Install from Disk (extensions, 4.2+)
# accept: one top folder vpffd_blender/ with __init__.py and blender_manifest.toml.
set -euo pipefail
cd "$(dirname "$0")/.."
version=$(sed -n 's/^version = "\(.*\)"/\1/p' blender/vpffd_blender/blender_manifest.toml)
mkdir -p dist
out="dist/vpffd_blender-${version}.zip"
rm -f "$out"
python3 - "$out" <<'PY'
import sys, zipfile
from pathlib import Path
src = Path("blender/vpffd_blender")
with zipfile.ZipFile(sys.argv[1], "w", zipfile.ZIP_DEFLATED) as z:
    for f in sorted(src.iterdir()):
        if f.is_file() and f.suffix in (".py", ".toml"):
            z.write(f, f"vpffd_blender/{f.name}")
PY
echo "$out"
