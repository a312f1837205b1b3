"""``dualpose reproduce TARGET``: re-run a paper's experiment and compare with its claims.

Each target lives in its own module with ``add_target(targets) -> ArgumentParser`` and ``run(args) -> int``:
``walker1991`` (:mod:`dualpose.cli.reproduce_walker1991`, Walker, Shao & Volz 1991) and ``screw-vector``
(:mod:`dualpose.cli.reproduce_screw`, the screw-vector relative-pose paper; docs/inertial.md).
"""

from __future__ import annotations

import argparse
from types import ModuleType

from dualpose.cli import reproduce_screw, reproduce_walker1991

TARGET_MODULES: tuple[ModuleType, ...] = (reproduce_walker1991, reproduce_screw)


def add_parser(subparsers: argparse._SubParsersAction[argparse.ArgumentParser]) -> argparse.ArgumentParser:
    """Register ``dualpose reproduce`` and its targets."""
    p = subparsers.add_parser("reproduce", help="re-run a paper's experiment (walker1991, screw-vector)")
    targets = p.add_subparsers(dest="target", required=True, metavar="TARGET")
    for module in TARGET_MODULES:
        module.add_target(targets).set_defaults(_run=module.run)
    return p


def run(args: argparse.Namespace) -> int:  # pragma: no cover - each target sets its own _run
    raise AssertionError(args.target)
