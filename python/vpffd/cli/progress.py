"""A tiny stderr progress bar for the command line (no dependencies)."""
from __future__ import annotations

import logging
import sys
import time

_log = logging.getLogger("vpffd.cli")


class Progress:
    """Progress bar on stderr that appears only once the work has taken
    ``delay`` seconds, so quick commands print nothing extra.

    Drawn in place with carriage returns on a terminal; off when stderr is not
    a terminal (logs and pipes stay clean) unless ``enabled`` is set.

    Each named stage (a new ``note``) is logged at INFO on the "vpffd.cli" logger,
    and a stage or a bar that took over ``delay`` seconds logs its time when it
    ends: ``vpffd -v`` shows these lines (once per stage, never per step).

    Parameters
    ----------
    label : str
    total : int
        number of steps; ``update(done)`` reports progress.
    delay : float
        seconds before the bar is first drawn.
    enabled : bool, optional
        default: stderr is a terminal.
    stream : file, optional
        default sys.stderr.
    """

    width = 28

    def __init__(self, label: str, total: int, delay: float = 1.0, enabled=None, stream=None):
        self.stream = sys.stderr if stream is None else stream
        if enabled is None:
            enabled = bool(getattr(self.stream, "isatty", lambda: False)())
        self.label, self.total, self.delay, self.enabled = label, max(int(total), 1), float(delay), enabled
        self.start = time.perf_counter()
        self.done = 0
        self._drawn = False
        self._last = 0.0
        self._stage, self._stage_start = None, self.start
        self._logged = False

    def update(self, done: int, total=None, note: str = "") -> None:
        """Reports ``done`` steps out of ``total`` (default: the total given at
        construction); redraws at most 20 times a second."""
        if total is not None:
            self.total = max(int(total), 1)
        self.done = int(done)
        now = time.perf_counter()
        if note and note != self._stage:
            self._end_stage(now)
            self._stage, self._stage_start = note, now
            _log.info("%s: %s", self.label, note)
        if not self.enabled:
            return
        if now - self.start < self.delay or (now - self._last < 0.05 and self.done < self.total):
            return
        self._last = now
        frac = min(self.done / self.total, 1.0)
        n = int(round(frac * self.width))
        bar = "#" * n + "-" * (self.width - n)
        text = f"\r{self.label} [{bar}] {self.done}/{self.total} {now - self.start:5.1f}s {note}"
        self.stream.write(text[:118].ljust(self._width_used() if self._drawn else 0))
        self.stream.flush()
        self._drawn = True
        self._used = len(text[:118])

    def _width_used(self) -> int:
        return getattr(self, "_used", 0)

    def __call__(self, done, total=None, *extra) -> None:
        # Accepts progress(done, total) and progress(i, n, name) callbacks alike.
        self.update(done, total, " ".join(str(e) for e in extra))

    def _end_stage(self, now) -> None:
        if self._stage is not None and now - self._stage_start >= self.delay:
            _log.info("%s: %s took %.1f s", self.label, self._stage, now - self._stage_start)
        self._stage = None

    def close(self) -> None:
        """Clears the bar's line (if it was drawn); logs the time of a stage or bar
        that took over ``delay`` seconds (once)."""
        now = time.perf_counter()
        self._end_stage(now)
        if not self._logged and now - self.start >= self.delay:
            _log.info("%s: %d/%d steps in %.1f s", self.label, self.done, self.total, now - self.start)
        self._logged = True
        if self._drawn:
            self.stream.write("\r" + " " * self._width_used() + "\r")
            self.stream.flush()
            self._drawn = False

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()
        return False
