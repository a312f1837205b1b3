"""``dualpose`` console script."""

from __future__ import annotations

import argparse
import sys


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="dualpose", description="Rigid-body pose with (dual) quaternions.")
    sub = parser.add_subparsers(dest="command", required=True)
    demo = sub.add_parser("demo", help="self-checking walk-through of the algebra on built-in data")
    demo.add_argument("--seed", type=int, default=7, help="seed of the random transforms (default 7)")
    return parser


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    if args.command == "demo":
        from dualpose.cli.demo import run_demo

        return run_demo(seed=args.seed)
    return 2  # pragma: no cover - argparse enforces the choices


if __name__ == "__main__":
    sys.exit(main())
