"""Checked numeric option types for argparse: a value out of range is a usage error (exit 2) naming the option.

``p.add_argument("--poses", type=int_in(2, 10**6), ...)``: argparse reports a rejected value as
``dualpose <cmd>: error: argument --poses: must be an integer in [2, 1000000]; got '1'``.
"""

from __future__ import annotations

import argparse
import math
from collections.abc import Callable

__all__ = ["SEED_MAX", "add_bag_time_argument", "float_in", "int_in", "seed"]

#: largest accepted ``--seed`` (numpy's generators take any non-negative integer; this keeps seeds printable)
SEED_MAX = 2**63 - 1


def _span(lo: float, hi: float, lo_open: bool) -> str:
    return f"{'(' if lo_open else '['}{lo:g}, {hi:g}]"


def float_in(lo: float, hi: float, lo_open: bool = False) -> Callable[[str], float]:
    """An argparse ``type``: a finite float in ``[lo, hi]`` (``(lo, hi]`` with ``lo_open``)."""

    def parse(text: str) -> float:
        try:
            x = float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"not a number: {text!r}") from None
        if not math.isfinite(x) or x > hi or x < lo or (lo_open and x == lo):
            raise argparse.ArgumentTypeError(f"must be a finite number in {_span(lo, hi, lo_open)}; got {text!r}")
        return x

    parse.__name__ = "number"
    return parse


def int_in(lo: int, hi: int) -> Callable[[str], int]:
    """An argparse ``type``: an integer in ``[lo, hi]``."""

    def parse(text: str) -> int:
        try:
            x = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"not an integer: {text!r}") from None
        if not lo <= x <= hi:
            raise argparse.ArgumentTypeError(f"must be an integer in [{lo}, {hi}]; got {text!r}")
        return x

    parse.__name__ = "integer"
    return parse


#: ``--seed``: a non-negative integer (numpy's ``default_rng`` refuses negative seeds)
seed = int_in(0, SEED_MAX)


def add_bag_time_argument(p: argparse.ArgumentParser) -> None:
    """``--bag-time header|receive``: the stamps of inputs read from ROS bag topics (``FILE.bag:/topic``)."""
    p.add_argument("--bag-time", choices=("header", "receive"), default="header",
                   help="stamps of inputs read from a ROS bag topic (FILE.bag:/topic, FILE.bag:/tf:PARENT:CHILD; "
                   ".db3 and .mcap too): the messages' header stamps (default) or the bag's receive times")  # fmt: skip
