"""``dualpose`` console script.

Each subcommand lives in its own module under :mod:`dualpose.cli` and exposes two functions:
``add_parser(subparsers) -> argparse.ArgumentParser`` and ``run(args) -> int``.  Registering a new subcommand is one
line in :data:`SUBCOMMANDS`; the modules import nothing heavy at module level: their computations are imported in
``run`` from :mod:`dualpose.pipelines` and the layers below.
"""

from __future__ import annotations

import argparse
import sys
from types import ModuleType

from dualpose.cli import ahrs, calibrate, demo, eval, fuse, register, reproduce

#: subcommand modules, in the order ``dualpose --help`` lists them
SUBCOMMANDS: tuple[ModuleType, ...] = (demo, register, reproduce, eval, fuse, ahrs, calibrate)


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="dualpose", description="Rigid-body pose with (dual) quaternions.")
    sub = parser.add_subparsers(dest="command", required=True)
    for module in SUBCOMMANDS:
        module.add_parser(sub).set_defaults(_run=module.run)
    return parser


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    return int(args._run(args))


if __name__ == "__main__":
    sys.exit(main())
