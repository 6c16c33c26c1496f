"""Fuzzer for vpffd's mesh readers: mutated files through vpffd.load_mesh in child processes.

    python tests/fuzz/fuzz_io.py --per-kind 1000 --seed 1 --out /tmp/fuzz-io

For every kind of file (see seeds.KINDS) it makes ``--per-kind`` mutants of the
seed corpus, and as many inputs of each strategy of seeds.STRATEGIES (every seed
cut at every byte; valid PLY files of every type; text files behind a UTF-8 byte-order
mark, which must load), deterministic for a given ``--seed``; writes them to a scratch
folder and loads them in batches, each batch in a fresh ``worker.py`` process
with a capped address space. An input passes when it gives a valid Mesh or a
vpffd.MeshIOError naming the file; a crash (signal, abort), a hang (no result
within ``--timeout`` seconds), another exception type or a peak-RSS jump is a
finding. A finding is confirmed by loading that input alone in a new process
and saved under ``OUT/findings/``; the batch resumes after it. Then ``--writes``
mesh and byte writes under random file-size limits (write_worker.py) check that a
failed write keeps the old file and leaves no temporary one. Exit status 1 when
anything was found. See tests/fuzz/README.md.
"""
from __future__ import annotations

import argparse
import json
import os
import random
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

import mutate  # noqa: E402
import seeds  # noqa: E402


def inputs(kind: str, corpus, count: int, seed: int):
    """``count`` inputs of ``kind`` (a seed kind's mutants, or a strategy of
    seeds.STRATEGIES): (name, bytes), deterministic. Valid files carry ".valid." in
    their names (the worker then counts a refusal as a finding)."""
    rng = random.Random(f"vpffd-fuzz-{seed}-{kind}")
    if kind == "truncated":
        # Every seed (but the gzipped ones: gzip's own checks decide those) cut at every
        # byte; `count` of them, drawn without repeats, or all.
        cuts = [(ext, data, n) for k in seeds.KINDS if k != "gz" for ext, data in corpus[k] for n in range(len(data))]
        for i, j in enumerate(sorted(rng.sample(range(len(cuts)), min(count, len(cuts))))):
            ext, data, n = cuts[j]
            yield f"truncated_{i:07d}.{ext}", data[:n]
        return
    if kind == "ply_types":
        for i in range(count):
            yield f"ply_types_{i:07d}.valid.ply", seeds.ply_typed(rng)
        return
    if kind == "bom":
        pool = [(ext, data) for k in seeds.TEXT_KINDS for ext, data in corpus[k]]
        for i in range(count):
            ext, data = pool[rng.randrange(len(pool))]
            yield f"bom_{i:07d}.valid.{ext}", b"\xef\xbb\xbf" + data
        return
    pool = corpus[kind]
    for i in range(count):
        ext, data = pool[rng.randrange(len(pool))]
        yield f"{kind}_{i:07d}.{ext}", mutate.mutate(rng, ext, data)


def run_batch(paths, as_mb: int, rss_mb: int, timeout: float):
    """Runs the worker on ``paths``; returns (results dict i -> str, index of a crash/hang or None, why)."""
    with tempfile.NamedTemporaryFile("wb", suffix=".lst", delete=False) as fh:
        fh.write(b"\n".join(os.fsencode(p) for p in paths))
        list_file = fh.name
    cmd = [sys.executable, str(HERE / "worker.py"), list_file, str(as_mb), str(rss_mb)]
    env = dict(os.environ, OMP_NUM_THREADS="1")
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, env=env)
    try:
        out, err = proc.communicate(timeout=timeout)
        hung = False
    except subprocess.TimeoutExpired:
        proc.kill()
        out, err = proc.communicate()
        hung = True
    finally:
        os.unlink(list_file)
    results, started = {}, None
    done = False
    for line in out.decode(errors="replace").splitlines():
        if line.startswith("S "):
            started = int(line.split()[1])
        elif line.startswith("R "):
            i, res = line[2:].split(" ", 1)
            results[int(i)] = res
        elif line == "DONE":
            done = True
    if done:
        return results, None, ""
    culprit = started if started is not None and started not in results else len(results)
    tail = err.decode(errors="replace").strip().splitlines()[-3:]
    if hung:
        why = f"hang: no result within {timeout:.0f} s"
    elif proc.returncode < 0:
        why = f"crash: signal {-proc.returncode}"
    else:
        why = f"crash: exit status {proc.returncode}"
    return results, culprit, why + (": " + " | ".join(tail) if tail else "")


def fuzz(per_kind: int, seed: int, out: Path, kinds=None, batch: int = 400, timeout: float = 20.0,
         as_mb: int = 1024, rss_mb: int = 512, log=print):
    """Runs the fuzzer; returns a summary dict (also written to OUT/summary.json)."""
    out.mkdir(parents=True, exist_ok=True)
    scratch = Path(tempfile.mkdtemp(prefix="vpffd-fuzz-"))
    summary = {"seed": seed, "per_kind": per_kind, "kinds": {}, "findings": []}
    try:
        corpus = seeds.seeds(str(scratch))
        for kind in kinds or seeds.KINDS + seeds.STRATEGIES:
            t0 = time.time()
            counts = {"ok": 0, "meshioerror": 0, "fail": 0}
            gen = inputs(kind, corpus, per_kind, seed)
            while True:
                chunk = []
                for name, data in gen:
                    p = scratch / name
                    p.write_bytes(data)
                    chunk.append(p)
                    if len(chunk) == batch:
                        break
                if not chunk:
                    break
                todo = chunk
                while todo:
                    # A generous per-batch timeout: a hang is found, then the input is retried alone.
                    results, bad, why = run_batch(todo, as_mb, rss_mb, timeout + 0.05 * len(todo))
                    for i, res in results.items():
                        if res.startswith("FAIL"):
                            counts["fail"] += 1
                            _finding(summary, out, todo[i], res[5:], log)
                        else:
                            counts[res] += 1
                    if bad is None:
                        break
                    alone, bad2, why2 = run_batch([todo[bad]], as_mb, rss_mb, timeout)
                    counts["fail"] += 1
                    confirmed = bad2 is not None or alone.get(0, "").startswith("FAIL")
                    _finding(summary, out, todo[bad], (why2 or alone.get(0, "").removeprefix("FAIL ")) if confirmed
                             else why + " (not reproduced alone)", log)
                    todo = todo[bad + 1:]
                for p in chunk:
                    p.unlink()
            dt = time.time() - t0
            summary["kinds"][kind] = dict(counts, inputs=sum(counts.values()), seconds=round(dt, 1))
            log(f"{kind}: {summary['kinds'][kind]}")
    finally:
        shutil.rmtree(scratch, ignore_errors=True)
    (out / "summary.json").write_text(json.dumps(summary, indent=1))
    return summary


def fuzz_writes(count: int, seed: int, timeout: float = 300.0) -> list[str]:
    """The write strategy: ``count`` writes under random file-size limits in a child
    (write_worker.py). Returns the findings (empty when every failed write kept its
    file and no temporary file was left)."""
    folder = tempfile.mkdtemp(prefix="vpffd-writes-")
    try:
        r = subprocess.run([sys.executable, str(HERE / "write_worker.py"), folder, str(count), str(seed)],
                           capture_output=True, text=True, timeout=timeout)
    finally:
        shutil.rmtree(folder, ignore_errors=True)
    findings = [line[5:] for line in r.stdout.splitlines() if line.startswith("FAIL ")]
    if f"DONE {count}" not in r.stdout:
        tail = " | ".join(r.stderr.strip().splitlines()[-3:])
        findings.append(f"the write worker stopped (exit status {r.returncode}): {tail}")
    return findings


def write_corpus(per_kind: int, seed: int, dest: Path, kinds=None) -> int:
    """Writes the same mutants ``fuzz`` would load (same seed, same names) into
    ``dest`` without loading them, for a replay through the C++ readers under the
    sanitizers (tests/fuzz/replay.cpp, scripts/sanitize.sh). Returns the count."""
    dest.mkdir(parents=True, exist_ok=True)
    scratch = Path(tempfile.mkdtemp(prefix="vpffd-fuzz-"))
    n = 0
    try:
        corpus = seeds.seeds(str(scratch))
        for kind in kinds or seeds.KINDS + seeds.STRATEGIES:
            for name, data in inputs(kind, corpus, per_kind, seed):
                (dest / name).write_bytes(data)
                n += 1
    finally:
        shutil.rmtree(scratch, ignore_errors=True)
    return n


def _finding(summary, out: Path, path: Path, why: str, log):
    dest = out / "findings"
    dest.mkdir(exist_ok=True)
    shutil.copy(path, dest / path.name)
    summary["findings"].append({"file": path.name, "why": why})
    log(f"FINDING {path.name}: {why}")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--per-kind", type=int, default=1000, help="mutants per kind of file")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--out", type=Path, default=Path("fuzz-io-out"))
    ap.add_argument("--kinds", nargs="*", choices=seeds.KINDS + seeds.STRATEGIES, help="default: all")
    ap.add_argument("--batch", type=int, default=400, help="inputs per child process")
    ap.add_argument("--timeout", type=float, default=20.0, help="seconds one input may take")
    ap.add_argument("--as-mb", type=int, default=1024, help="address space a child may add after importing vpffd")
    ap.add_argument("--write-only", type=Path, metavar="DIR",
                    help="only write the mutants into DIR (for tests/fuzz/replay.cpp under the sanitizers)")
    ap.add_argument("--writes", type=int, default=200, help="writes under random file-size limits (0: none)")
    args = ap.parse_args(argv)
    if args.write_only:
        n = write_corpus(args.per_kind, args.seed, args.write_only, args.kinds)
        print(f"{n} inputs written to {args.write_only}")
        return 0
    s = fuzz(args.per_kind, args.seed, args.out, args.kinds, args.batch, args.timeout, args.as_mb)
    total = sum(k["inputs"] for k in s["kinds"].values())
    print(f"{total} inputs, {len(s['findings'])} findings; summary in {args.out / 'summary.json'}")
    writes = fuzz_writes(args.writes, args.seed) if args.writes else []
    for w in writes:
        print(f"write finding: {w}")
    if args.writes:
        print(f"{args.writes} writes under file-size limits, {len(writes)} findings")
    return 1 if s["findings"] or writes else 0


if __name__ == "__main__":
    sys.exit(main())
