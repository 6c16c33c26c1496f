"""Child process of the fuzzer's write strategy: failed writes must never cost a file.

Usage: python write_worker.py FOLDER COUNT SEED

Each case writes a mesh (save_mesh, a random format) or bytes (vpffd._files) over an
existing file under a random file-size limit (RLIMIT_FSIZE, from 0 to past the new
file's size). The write must either succeed, leaving the new content, or raise
MeshIOError naming the file, leaving the old bytes; either way no temporary file may
remain. Prints ``FAIL <case> <why>`` for each case that breaks this, then ``DONE n``.
"""
import os
import random
import resource
import sys


def main():
    folder, count, seed = sys.argv[1], int(sys.argv[2]), int(sys.argv[3])
    import numpy as np

    import vpffd
    from vpffd import shapes
    from vpffd._files import write_bytes
    rng = random.Random(f"vpffd-writes-{seed}")
    hard = resource.getrlimit(resource.RLIMIT_FSIZE)[1]
    meshes = [shapes.icosphere(k) for k in (1, 2, 3)]
    for case in range(count):
        ext = rng.choice(["ply", "obj", "off", "stl", "om", "bin"])
        target = os.path.join(folder, f"case{case}.{ext}")
        old = bytes(rng.randrange(256) for _ in range(rng.randrange(1, 2000)))
        with open(target, "wb") as fh:
            fh.write(old)
        mesh = meshes[rng.randrange(len(meshes))]
        new = bytes(rng.randrange(256) for _ in range(rng.randrange(0, 100_000)))
        limit = rng.randrange(0, 150_000)
        resource.setrlimit(resource.RLIMIT_FSIZE, (limit, hard))
        outcome = None
        try:
            if ext == "bin":
                write_bytes(target, new)
            else:
                vpffd.save_mesh(target, mesh)
            outcome = "ok"
        except vpffd.MeshIOError as e:
            outcome = "refused" if os.path.basename(target) in str(e) else f"message without the file: {e}"
        except BaseException as e:  # noqa: BLE001 - any other exception is a finding
            outcome = f"{type(e).__name__}: {e}"
        finally:
            resource.setrlimit(resource.RLIMIT_FSIZE, (hard, hard))
        with open(target, "rb") as fh:
            now = fh.read()
        left = [n for n in os.listdir(folder) if n != os.path.basename(target) and not n.startswith("case")]
        why = None
        if outcome == "ok":
            if ext == "bin" and now != new:
                why = "the write succeeded but the file does not hold the new bytes"
            elif ext != "bin":
                got = vpffd.load_mesh(target).vertices
                want = mesh.vertices
                if ext == "stl":  # no shared vertices: the reader merges equal positions in its own order
                    got, want = np.unique(got.round(5), axis=0), np.unique(want.round(5), axis=0)
                if got.shape != want.shape or not np.allclose(got, want, atol=1e-5):
                    why = "the write succeeded but the file does not hold the new mesh"
        elif outcome == "refused":
            if now != old:
                why = f"the write failed and the old file changed ({len(old)} -> {len(now)} bytes)"
        else:
            why = outcome
        if left:
            why = (why + "; " if why else "") + f"files left behind: {left}"
        if why:
            print(f"FAIL case{case}.{ext} limit {limit}: {why}", flush=True)
        os.unlink(target)
    print(f"DONE {count}", flush=True)


if __name__ == "__main__":
    main()
