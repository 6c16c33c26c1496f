"""``python -m vpffd``: the ``vpffd`` command (see ``vpffd.cli.main``)."""
import sys

from .cli.main import main

if __name__ == "__main__":
    sys.exit(main())
