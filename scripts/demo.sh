#!/usr/bin/env bash
# The main job: install, build, and run the demo on built-in meshes.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
.venv/bin/python -m vpffd demo "$@"
