#!/usr/bin/env bash
# Per-frame counts of one xyz frame under valgrind's cachegrind: instructions,
# first-level and last-level data misses (simulated caches) and branch mispredicts.
# They do not move with the machine's load, so two builds of bench_frame can be
# compared where timings are too noisy to decide (a shared VM); they are not times:
# a miss that the hardware prefetcher hides costs little, and the branch model is
# simpler than a CPU's.
#
#   bench/cachegrind_frame.sh [--moves] BENCH_FRAME_BINARY [icosphere LEVEL | PLY_FILE]
#
# Runs the binary with --frames 1 and --frames 4 (the two at once) and prints the
# difference / 3: the Deformer's construction cancels. With --moves: per move of the
# rest mesh (set_rest_vertices) instead of per frame. The last-level cache is
# simulated at LL_BYTES (default 4 MiB, a core's share of a typical L3), so that the
# dragon's data (~100 MB) does not fit in it. About 5 minutes for the dragon.
set -euo pipefail
mode=--frames
what="xyz frame"
if [[ ${1:-} == --moves ]]; then
  mode=--moves
  what="move of the rest mesh"
  shift
fi
bin=${1:?usage: cachegrind_frame.sh [--moves] BENCH_FRAME_BINARY [icosphere LEVEL | PLY_FILE]}
shift
command -v valgrind >/dev/null || { echo "cachegrind_frame.sh: needs valgrind (apt-get install valgrind)" >&2; exit 1; }
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
for n in 1 4; do
  OMP_NUM_THREADS=1 valgrind --tool=cachegrind --cache-sim=yes --branch-sim=yes \
    --LL="${LL_BYTES:-4194304}",16,64 --cachegrind-out-file="$tmp/out.$n" \
    "$bin" "$mode" "$n" "$@" >"$tmp/stdout.$n" 2>"$tmp/log.$n" &
done
wait
cat "$tmp/stdout.4"
python3 - "$tmp" "$what" <<'PY'
import re, sys
def counts(path):
    text = open(path).read()
    get = lambda label: int(re.search(label + r":\s+([\d,]+)", text).group(1).replace(",", ""))
    return {"instructions": get(r"I\s+refs"), "D1 misses": get(r"D1\s+misses"),
            "LL misses": get(r"LL misses"), "mispredicts": get(r"Mispredicts")}
a, b = counts(f"{sys.argv[1]}/log.1"), counts(f"{sys.argv[1]}/log.4")
print(f"per {sys.argv[2]} (1 thread): " + ", ".join(f"{k} {(b[k] - a[k]) / 3 / 1e6:.2f} M" for k in a))
PY
