"""Real gyro data (docs/inertial.md §7): noise and bias dominate the algorithm choice."""


import numpy as np
import pytest

from dualpose.io import load_broad
from dualpose.pipelines.inertial_broad import ALGORITHMS, window_errors
from realdata import data_dir

BROAD = data_dir("broad", full=True)


def test_algorithm_spread_is_far_below_the_error():
    if not BROAD.is_dir():
        pytest.skip("BROAD data directory missing")
    trial = load_broad(BROAD / "21_undisturbed_fast_combined.mat")
    e = window_errors(trial, 10.0)
    assert e["spread"].size >= 5
    errs = np.array([e[label] for label, _, _ in ALGORITHMS])
    assert np.all(errs.mean(axis=1) > 1.0)  # degrees after 10 s, every algorithm
    assert e["spread"].max() < 0.05 * errs.mean()  # the algorithms differ by < 5 % of the error
