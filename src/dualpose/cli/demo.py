"""``dualpose demo``: a short self-checking walk-through of the quaternion / dual-quaternion algebra.

The walk-through is :func:`dualpose.pipelines.demo.algebra_walkthrough`; this module prints its transforms, the
ScLERP path and a table of checks, and returns 0 only if every check is within its tolerance.
"""

from __future__ import annotations

import argparse

import numpy as np

from dualpose.cli._args import seed


def _table(rows: list[tuple[str, str]]) -> None:
    from dualpose.cli._output import aligned_rows

    print(aligned_rows(rows, indent="  "))


def run_demo(seed: int = 7) -> int:
    """Run the walk-through (:func:`dualpose.pipelines.demo.algebra_walkthrough`) and print it; returns 0 if all
    checks pass, 1 otherwise."""
    from dualpose.pipelines.demo import algebra_walkthrough

    res = algebra_walkthrough(seed)
    print("dualpose demo: dual quaternions [real xyzw, dual xyzw], dual = 1/2 t (x) real\n")
    print("transforms")
    _table([(name, np.array2string(dq, precision=4, suppress_small=True)) for name, dq in res.transforms.items()])
    print("\nScLERP from A to A (x) B")
    print(f"  {'t':>5}  {'angle from A [deg]':>18}  {'advance along axis':>18}  translation")
    for t, ang, adv, tr in res.sclerp:
        print(f"  {t:5.2f}  {ang:18.6f}  {adv:18.6f}  {np.array2string(tr, precision=6)}")
    print("\nchecks")
    width = max(len(c.name) for c in res.checks)
    print(f"  {'check':<{width}}  {'max error':>10}  {'tolerance':>9}  result")
    for c in res.checks:
        print(f"  {c.name:<{width}}  {c.error:10.2e}  {c.tolerance:9.0e}  {'ok' if c.passed else 'FAIL'}")
    print("\nall checks passed" if res.passed else "\nSOME CHECKS FAILED")
    return 0 if res.passed else 1


def add_parser(subparsers: argparse._SubParsersAction[argparse.ArgumentParser]) -> argparse.ArgumentParser:
    """Register ``dualpose demo``."""
    demo = subparsers.add_parser("demo", help="self-checking walk-through of the algebra on built-in data")
    demo.add_argument("--seed", type=seed, default=7, help="seed of the random transforms (default 7; >= 0)")
    return demo


def run(args: argparse.Namespace) -> int:
    """Entry point of ``dualpose demo``."""
    return run_demo(seed=args.seed)
