"""Compile (or load from the on-disk cache) every numba kernel once: ``python -m dualpose.warmup``.

The Makefile runs this after installing so that parallel test workers find a warm cache.
"""

from __future__ import annotations

import importlib
import time

KERNEL_MODULES = (
    "dualpose.algebra.series",
    "dualpose.algebra._dualquat_kernels",
    "dualpose.algebra._lie_kernels",
    "dualpose.estimation._eskf_kernels",
    "dualpose.estimation._smoother_kernels",
    "dualpose.estimation._hol22_kernels",
    "dualpose.estimation._ahrs_kernels",
)


def warmup() -> float:
    """Import every kernel module; returns the seconds it took."""
    from dualpose._kernel_cache import ensure_fresh, mark_fresh

    t0 = time.perf_counter()
    ensure_fresh()
    for name in KERNEL_MODULES:
        importlib.import_module(name)
    mark_fresh()
    return time.perf_counter() - t0


if __name__ == "__main__":
    print(f"dualpose kernels ready in {warmup():.1f} s")
