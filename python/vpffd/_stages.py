"""The stage reporter of the long precomputations (the multiresolution
decompositions): what the C++ side calls after each stage, logged and handed on to
the caller's ``progress(done, total)``."""
from __future__ import annotations

import logging

from ._core import InvalidInputError


def stage_reporter(who: str, figure: str, progress, log: logging.Logger):
    """A callable ``(stage, done, total, value)`` for the C++ decompositions: logs
    "<who>: <stage> (done/total), <figure> <value>" at INFO and calls
    ``progress(done, total)`` when given. Refuses a ``progress`` that is not callable."""
    if progress is not None and not callable(progress):
        raise InvalidInputError(f"{who}: progress must be callable, got {progress!r}")

    def stage(name, done, total, value):
        log.info("%s: %s (%d/%d), %s %.4g", who, name, done, total, figure, value)
        if progress is not None:
            progress(done, total)
    return stage
