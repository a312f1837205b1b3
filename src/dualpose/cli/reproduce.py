"""``dualpose reproduce TARGET``: re-run a paper's experiment and compare with its claims.

Each target lives in its own module with ``add_target(targets) -> ArgumentParser`` and ``run(args) -> int``:
``walker1991`` (:mod:`dualpose.cli.reproduce_walker1991`, issue 3) and ``screw-vector``
(:mod:`dualpose.cli.reproduce_screw`, issue 4).
"""

from __future__ import annotations

import argparse
import importlib

TARGET_MODULES: tuple[str, ...] = ("dualpose.cli.reproduce_walker1991", "dualpose.cli.reproduce_screw")


def add_parser(subparsers: argparse._SubParsersAction) -> argparse.ArgumentParser:
    """Register ``dualpose reproduce`` and its targets."""
    p = subparsers.add_parser("reproduce", help="re-run a paper's experiment (walker1991, screw-vector)")
    targets = p.add_subparsers(dest="target", required=True, metavar="TARGET")
    for name in TARGET_MODULES:
        module = importlib.import_module(name)
        module.add_target(targets).set_defaults(_run=module.run)
    return p


def run(args: argparse.Namespace) -> int:  # pragma: no cover - each target sets its own _run
    raise AssertionError(args.target)
