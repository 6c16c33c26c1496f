"""The memory floor the frame benchmarks hold their times to (bench_core.py, bench_gpu.py).

A frame's least memory traffic is its result written once: the caller's (V, 3) float64
vertices, 24 bytes a vertex (the control points are negligible beside them). Its floor
is that traffic at this machine's copy bandwidth, measured in the same run; a row's
ratio to the floor says how far from that limit the frame is (a frame that reads and
writes its vertices several times sits several floors above it).
"""
import statistics
import time

import numpy as np

RESULT_BYTES_PER_VERTEX = 24


def copy_bandwidth(megabytes: int = 512, repeats: int = 5) -> float:
    """Bytes per second of a large copy: bytes read plus bytes written by np.copyto of
    `megabytes` of float64 (far beyond any cache), the median of `repeats` after one
    untimed copy that faults the pages in."""
    n = megabytes * 2 ** 20 // 8
    src, dst = np.ones(n), np.empty(n)
    np.copyto(dst, src)
    t = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        np.copyto(dst, src)
        t.append(time.perf_counter() - t0)
    return 2 * 8 * n / statistics.median(t)


def floor_ms(vertices: int, bandwidth: float) -> float:
    """The floor of a frame of `vertices` vertices, ms."""
    return RESULT_BYTES_PER_VERTEX * vertices / bandwidth * 1e3


def note(bandwidth: float) -> str:
    return (f"floor: the caller's float64 vertices written once ({RESULT_BYTES_PER_VERTEX} bytes a vertex) at "
            f"{bandwidth / 1e9:.1f} GB/s, this run's np.copyto of 512 MB (bytes read + written, median of 5); "
            "a time / floor of 10 is ten times that floor")
