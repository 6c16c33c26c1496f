"""Refuses, with a clear message, to load a _core built for a newer x86 ISA level
than this CPU has (it would die with SIGILL instead)."""
from __future__ import annotations

from pathlib import Path

_NEEDS = {"x86-64-v2": {"sse4_2", "popcnt", "ssse3"},
          "x86-64-v3": {"sse4_2", "popcnt", "avx", "avx2", "fma", "bmi2", "f16c", "movbe"}}


def check_isa() -> None:
    f = Path(__file__).with_name("_build_isa.txt")
    if not f.exists():
        return
    isa = f.read_text().strip()
    need = _NEEDS.get(isa)
    cpuinfo = Path("/proc/cpuinfo")
    if not need or not cpuinfo.exists():
        return
    for line in cpuinfo.read_text().splitlines():
        if line.startswith("flags"):
            missing = need - set(line.split(":", 1)[1].split())
            if missing:
                raise ImportError(
                    f"vpffd was built for {isa} but this CPU lacks {', '.join(sorted(missing))}; rebuild with "
                    f"pip install . -Ccmake.define.VPFFD_ISA=x86-64")
            return
