"""Gyro-only attitude integration on the shared BROAD trials with every algorithm: the table of docs/inertial.md §7.

Run ``.venv/bin/python benchmarks/inertial_broad.py [DIR]`` (DIR defaults to ``<repo>/../shared/data/broad``).
"""

from __future__ import annotations

import sys
from pathlib import Path

from dualpose.pipelines.inertial_broad import broad_table

DEFAULT = Path(__file__).resolve().parents[1] / ".." / "shared" / "data" / "broad"


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    print(broad_table(argv[0] if argv else DEFAULT))
    return 0


if __name__ == "__main__":
    sys.exit(main())
