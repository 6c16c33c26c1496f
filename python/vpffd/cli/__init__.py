"""The application built on the library: the ``vpffd`` command (``main``), the
demo (``demo``) and the benchmark helpers (``benchmark``). Nothing here is
imported by ``import vpffd``; the library never depends on this package."""
