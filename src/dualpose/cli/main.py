"""``dualpose`` console script.

Each subcommand lives in its own module under :mod:`dualpose.cli` and exposes two functions:
``add_parser(subparsers) -> argparse.ArgumentParser`` and ``run(args) -> int``.  Registering a new subcommand is one
line in :data:`SUBCOMMANDS`; modules are imported only when the parser is built, and their heavy imports belong in
``run``.
"""

from __future__ import annotations

import argparse
import importlib
import sys

#: subcommand modules, in the order ``dualpose --help`` lists them
SUBCOMMANDS: tuple[str, ...] = (
    "dualpose.cli.demo",
    "dualpose.cli.register",
    "dualpose.cli.reproduce",
    "dualpose.cli.eval",
    "dualpose.cli.fuse",
    "dualpose.cli.ahrs",
    "dualpose.cli.calibrate",
)


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="dualpose", description="Rigid-body pose with (dual) quaternions.")
    sub = parser.add_subparsers(dest="command", required=True)
    for name in SUBCOMMANDS:
        module = importlib.import_module(name)
        module.add_parser(sub).set_defaults(_run=module.run)
    return parser


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    return int(args._run(args))


if __name__ == "__main__":
    sys.exit(main())
