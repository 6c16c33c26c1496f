"""Deprecated location: the application moved to ``vpffd.cli.benchmark``; this alias
goes away in the next release."""
import warnings as _warnings

from .cli.benchmark import *  # noqa: F401,F403
from .cli import benchmark as _moved

_warnings.warn("vpffd.benchmark moved to vpffd.cli.benchmark; the old name goes away in the next release",
               DeprecationWarning, stacklevel=2)


def __getattr__(name):
    # Private helpers too, for one release.
    return getattr(_moved, name)
