"""Output arrays that frames reuse once their caller has let go of them.

A frame without ``out=`` returns a new (V, 3) array; for a large mesh that array is
mapped fresh from the operating system every call and faulted in page by page
(a 2.6M-vertex frame writes 63 MB). A deformer keeps the array of its last frame of
each kind here and hands it to the next frame of that kind as its ``out`` when
nobody else holds it any more: no reference from the caller, no view of it, no
result that contains it (reference counts say so; a build whose counts are not
exact simply never reuses). The caller sees no difference but the speed: a kept
array, or any view of it, is never written again.

The lifetime rule, for raw pointers only: an address taken from a result array
(``arr.ctypes.data``, ``__array_interface__``) is valid while the array is held;
once it is dropped, a later frame may write there.

Thread-safe: a frame takes the spare out of the table (one dict operation, atomic
under the GIL) before it checks it, so two frames never share one.
"""

from __future__ import annotations

import sys

import numpy as np

__all__ = ["Spares"]


class Spares:
    """The last output array of each frame kind of one deformer."""

    __slots__ = ("_arrays",)

    def __init__(self):
        self._arrays: dict = {}

    def take(self, kind: str, shape: tuple):
        """An array of ``shape`` nobody else holds, to write the next frame into, or None."""
        a = self._arrays.pop(kind, None)
        # Held by `a` and getrefcount's argument only: the caller has let go of it.
        if a is None or a.shape != shape or not a.flags.writeable or sys.getrefcount(a) != 2:
            return None
        return a

    def keep(self, kind: str, a) -> None:
        """Remembers the array a frame returned, for a later frame."""
        # Not a view (whose memory belongs to another array, the caller's perhaps).
        if a is not None and not isinstance(a.base, np.ndarray):
            self._arrays[kind] = a
