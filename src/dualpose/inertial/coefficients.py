"""Cross-product coefficients of the N-sample rotation-vector (coning) algorithms.

An N-sample algorithm computes the rotation vector of one update (length ``T = N h``) from the body-frame angle
increments ``θ_1 … θ_N`` of its sub-intervals as::

    Φ = Σ_i θ_i + s Σ_{i<j} k_ij θ_i × θ_j                                  (docs/inertial.md §2; paper eqs. (17)-(21))

with ``s = +1`` for body-frame increments (right multiplication) and ``s = −1`` for inertial-frame increments
(left multiplication).  Two families are tabulated (exact rationals):

``"polynomial"``
    The angular rate is fitted by a polynomial of degree N−1 through the N increments and the Bortz correction
    ``½ ∫ α × ω dt`` is integrated exactly (Jiang & Lin 1992; N = 3: 33/80, 57/80; N = 4: 736/945, 334/945,
    526/945, 654/945).
``"coning-optimal"``
    The sums ``K_l = Σ_{j−i=l} k_ij`` are chosen so that the algorithm reproduces the exact coning correction
    ``½ sin²a (ΩT − sin ΩT)`` to order ``(ΩT)^{2N−1}`` (Miller 1983; Ignagni 1990), the coefficient spread evenly
    over pairs of equal lag (N = 3: 9/20, 27/40; N = 4: 54/105, 46/105, 214/315).  The coning drift is then
    ``ε_N = ρ_N a² Ω (ΩT)^{2N}`` with ``ρ = 1/12, 1/960, 1/204120, 1/82575360``.

For N ≤ 2 the two families coincide.  ``"one-plus-previous"`` (N = 1 only) uses the last increment of the previous
update: ``Φ_k = θ_k + s (1/12) θ_{k−1} × θ_k`` (Savage 1998).
"""

from __future__ import annotations

from fractions import Fraction as Fr

import numpy as np
from numpy.typing import NDArray

__all__ = ["FAMILIES", "MAX_SAMPLES", "coning_coefficients", "PREVIOUS_COEFFICIENT"]

FAMILIES = ("coning-optimal", "polynomial", "one-plus-previous")
MAX_SAMPLES = 4
#: coefficient of θ_{k−1} × θ_k in the one-plus-previous algorithm
PREVIOUS_COEFFICIENT = Fr(1, 12)

# (i, j) -> k_ij, 1-based sample indices, i < j
_TABLES: dict[tuple[str, int], dict[tuple[int, int], Fr]] = {
    ("polynomial", 1): {},
    ("polynomial", 2): {(1, 2): Fr(2, 3)},
    ("polynomial", 3): {(1, 2): Fr(57, 80), (1, 3): Fr(33, 80), (2, 3): Fr(57, 80)},
    ("polynomial", 4): {
        (1, 2): Fr(736, 945),
        (3, 4): Fr(736, 945),
        (1, 3): Fr(334, 945),
        (2, 4): Fr(334, 945),
        (1, 4): Fr(526, 945),
        (2, 3): Fr(654, 945),
    },
    ("coning-optimal", 1): {},
    ("coning-optimal", 2): {(1, 2): Fr(2, 3)},
    ("coning-optimal", 3): {(1, 2): Fr(27, 40), (2, 3): Fr(27, 40), (1, 3): Fr(9, 20)},
    ("coning-optimal", 4): {
        (1, 2): Fr(214, 315),
        (2, 3): Fr(214, 315),
        (3, 4): Fr(214, 315),
        (1, 3): Fr(46, 105),
        (2, 4): Fr(46, 105),
        (1, 4): Fr(54, 105),
    },
    ("one-plus-previous", 1): {},
}


def check_algorithm(samples: object, coefficients: object) -> tuple[int, str]:
    """Validate ``samples`` (int 1..4) and ``coefficients`` (a family name); returns them normalized."""
    if isinstance(samples, bool) or not isinstance(samples, int | np.integer):
        raise TypeError(f"samples must be an integer in 1..{MAX_SAMPLES}; got {samples!r}")
    samples = int(samples)
    if not 1 <= samples <= MAX_SAMPLES:
        raise ValueError(f"samples must be in 1..{MAX_SAMPLES}; got {samples}")
    if coefficients not in FAMILIES:
        raise ValueError(f"coefficients must be one of {FAMILIES}; got {coefficients!r}")
    if coefficients == "one-plus-previous" and samples != 1:
        raise ValueError(f"coefficients='one-plus-previous' needs samples=1; got samples={samples}")
    return samples, str(coefficients)


def coning_coefficients(samples: int, coefficients: str = "coning-optimal", exact: bool = False) -> NDArray[np.float64]:
    """Matrix ``K`` (shape ``(N, N)``, strictly upper triangular) with ``Φ = Σ θ_i + Σ_{i<j} K[i, j] θ_i × θ_j``.

    Parameters
    ----------
    samples : int
        N, the number of increments per update (1..4).
    coefficients : {"coning-optimal", "polynomial", "one-plus-previous"}
        The coefficient family (see the module docstring).  "one-plus-previous" has no within-update terms.
    exact : bool
        Return ``fractions.Fraction`` objects (dtype object) instead of float64.

    Returns
    -------
    ndarray, shape (N, N)
        0-based indices: ``K[0, 1]`` multiplies ``θ_1 × θ_2``.
    """
    samples, coefficients = check_algorithm(samples, coefficients)
    out = np.full((samples, samples), Fr(0), dtype=object)
    for (i, j), k in _TABLES[(coefficients, samples)].items():
        out[i - 1, j - 1] = k
    return out if exact else out.astype(np.float64)
