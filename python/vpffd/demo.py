"""Deprecated location: the application moved to ``vpffd.cli.demo``; this alias
goes away in the next release."""
import warnings as _warnings

from .cli.demo import *  # noqa: F401,F403
from .cli import demo as _moved

_warnings.warn("vpffd.demo moved to vpffd.cli.demo; the old name goes away in the next release",
               DeprecationWarning, stacklevel=2)


def __getattr__(name):
    # Private helpers too, for one release.
    return getattr(_moved, name)
