"""Child process of the fuzzer: loads each file of a batch with vpffd.load_mesh.

Usage: python worker.py LISTFILE ADDRESS_SPACE_MB RSS_GROWTH_MB

Prints ``S i`` before input i and ``R i ok|meshioerror|FAIL <why>`` after it
(flushed), then ``DONE``. The parent reads these lines: an input that was
started but has no result crashed the process (abort, segfault) or hung. The
address space is capped (RLIMIT_AS) after the import, so an attempt to allocate
gigabytes fails inside the process instead of swapping the machine.
"""
import os
import resource
import sys


def check_mesh(mesh):
    import numpy as np
    V, F = mesh.vertices, mesh.faces
    if not (isinstance(V, np.ndarray) and V.dtype == np.float64 and V.ndim == 2 and V.shape[1] == 3):
        return f"vertices are not (n, 3) float64: {getattr(V, 'dtype', type(V))} {getattr(V, 'shape', '')}"
    if not (isinstance(F, np.ndarray) and F.dtype == np.int32 and F.ndim == 2 and F.shape[1] == 3):
        return f"faces are not (m, 3) int32: {getattr(F, 'dtype', type(F))} {getattr(F, 'shape', '')}"
    if len(V) == 0 or len(F) == 0:
        return "empty mesh returned without an error"
    if not np.isfinite(V).all():
        return "non-finite vertex returned"
    if F.min() < 0 or F.max() >= len(V):
        return f"face index out of range [0, {len(V)}): {F.min()}..{F.max()}"
    return None


def main():
    list_file, as_mb, rss_mb = sys.argv[1], int(sys.argv[2]), int(sys.argv[3])
    import vpffd
    with open(list_file, "rb") as fh:
        paths = [os.fsdecode(p) for p in fh.read().split(b"\n") if p]
    # Cap the address space relative to what the interpreter already maps.
    with open("/proc/self/statm") as fh:
        mapped = int(fh.read().split()[0]) * resource.getpagesize()
    limit = mapped + as_mb * 2**20
    resource.setrlimit(resource.RLIMIT_AS, (limit, limit))
    base_rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss  # KiB
    out = sys.stdout
    for i, p in enumerate(paths):
        out.write(f"S {i}\n")
        out.flush()
        try:
            mesh = vpffd.load_mesh(p)
        except vpffd.MeshIOError as e:
            msg = str(e)
            name = os.path.basename(p)
            why = None if name in msg else f"message does not name the file: {msg[:200]!r}"
            if why is None and ".valid." in name:
                why = f"a valid file was refused: {msg[:300]!r}"
            result = "meshioerror" if why is None else "FAIL " + why
        except BaseException as e:  # noqa: BLE001 - any other exception is the finding
            result = f"FAIL {type(e).__name__}: {str(e)[:300]!r}"
        else:
            why = check_mesh(mesh)
            result = "ok" if why is None else "FAIL " + why
            del mesh
        grown = (resource.getrusage(resource.RUSAGE_SELF).ru_maxrss - base_rss) / 1024
        if grown > rss_mb and not result.startswith("FAIL"):
            result = f"FAIL peak RSS grew by {grown:.0f} MiB (bound {rss_mb} MiB)"
            base_rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
        out.write(f"R {i} {result}\n".replace("\n", " ").rstrip() + "\n")
        out.flush()
    out.write("DONE\n")
    out.flush()


if __name__ == "__main__":
    main()
