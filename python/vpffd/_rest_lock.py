"""The lock between a deformer's frames and the moves of its rest mesh.

Frames (``ffd``, ``deform``, ``check_folds``, ...) read the rest state and run side by
side; a move (``set_rest_vertices``, ``set_rest_offsets``) changes it, together with
the Python bookkeeping around it (the rest mesh, the offsets' base, the rest volume's
source), and must run alone, so that a frame sees the state before the move or after
it, never a mix. The lock prefers the mover: a waiting move holds back frames that have
not started, so threads drawing frames back to back cannot starve it; when it ends,
the frames that waited for it go first, so moves back to back cannot starve them. A
thread that already holds the lock, shared or exclusive, may take it shared again (a
frame calls other frame methods, a move reads the rest mesh); taking it exclusive
while holding it shared is refused, because it could never be granted.
"""

from __future__ import annotations

import threading

__all__ = ["RestLock"]


class RestLock:
    """Writer-preferring, reader-reentrant lock: ``with lock.shared():`` for frames,
    ``with lock.exclusive():`` for moves."""

    __slots__ = ("_cond", "_readers", "_writer", "_writers_waiting", "_readers_waiting", "_admitted", "_shared",
                 "_exclusive")

    def __init__(self):
        self._cond = threading.Condition(threading.Lock())
        self._readers: dict[int, int] = {}  # thread ident -> depth
        self._writer: int | None = None
        self._writers_waiting = 0
        self._readers_waiting = 0
        self._admitted = 0  # frames that waited for a move, let in ahead of the next one
        self._shared = _Shared(self)
        self._exclusive = _Exclusive(self)

    def shared(self):
        """Context manager: a frame's hold (many at once, none during a move)."""
        return self._shared

    def exclusive(self):
        """Context manager: a move's hold (alone; waits for the frames in flight)."""
        return self._exclusive

    def _acquire_shared(self) -> bool:
        me = threading.get_ident()
        with self._cond:
            if self._writer == me:
                return False  # inside this thread's own move: nothing to take
            depth = self._readers.get(me)
            if depth is not None:
                self._readers[me] = depth + 1
                return True
            if self._writer is not None or (self._writers_waiting and not self._admitted):
                self._readers_waiting += 1
                try:
                    while self._writer is not None or (self._writers_waiting and not self._admitted):
                        self._cond.wait()
                finally:
                    self._readers_waiting -= 1
            if self._admitted:
                self._admitted -= 1
            self._readers[me] = 1
            return True

    def _release_shared(self) -> None:
        me = threading.get_ident()
        with self._cond:
            depth = self._readers[me] - 1
            if depth:
                self._readers[me] = depth
                return
            del self._readers[me]
            if not self._readers and not self._admitted:
                self._cond.notify_all()

    def _acquire_exclusive(self) -> None:
        me = threading.get_ident()
        with self._cond:
            if me in self._readers:
                raise RuntimeError("a rest move was started inside a frame on the same thread: it would wait for "
                                   "that frame for ever; move the rest mesh between frames")
            if self._writer == me:
                raise RuntimeError("a rest move was started inside another rest move on the same thread")
            self._writers_waiting += 1
            try:
                while self._writer is not None or self._readers or self._admitted:
                    self._cond.wait()
            finally:
                self._writers_waiting -= 1
                self._cond.notify_all()  # frames held back by this move may go on should it fail
            self._writer = me

    def _release_exclusive(self) -> None:
        with self._cond:
            self._writer = None
            self._admitted = self._readers_waiting  # the frames that waited go first
            self._cond.notify_all()


class _Shared:
    __slots__ = ("_lock", "_held")

    def __init__(self, lock: RestLock):
        self._lock = lock
        self._held = threading.local()

    def __enter__(self):
        took = self._lock._acquire_shared()
        stack = getattr(self._held, "stack", None)
        if stack is None:
            stack = self._held.stack = []
        stack.append(took)
        return self

    def __exit__(self, *exc):
        if self._held.stack.pop():
            self._lock._release_shared()
        return False


class _Exclusive:
    __slots__ = ("_lock",)

    def __init__(self, lock: RestLock):
        self._lock = lock

    def __enter__(self):
        self._lock._acquire_exclusive()
        return self

    def __exit__(self, *exc):
        self._lock._release_exclusive()
        return False
