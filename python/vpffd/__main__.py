"""The ``vpffd`` command."""
from __future__ import annotations

import argparse
import sys


def _demo(args) -> int:
    from .demo import run_demo
    run_demo(quick=args.quick)
    return 0


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="vpffd", description="Volume-preserving free-form deformation.")
    sub = parser.add_subparsers(dest="command", required=True)
    p = sub.add_parser("demo", help="deform built-in meshes with and without volume preservation")
    p.add_argument("--quick", action="store_true", help="fewer frames")
    p.set_defaults(func=_demo)
    args = parser.parse_args(argv)
    try:
        return args.func(args)
    except (ValueError, RuntimeError, OSError) as e:
        print(f"vpffd {args.command}: error: {e}", file=sys.stderr)
        return 1


if __name__ == "__main__":
    sys.exit(main())
