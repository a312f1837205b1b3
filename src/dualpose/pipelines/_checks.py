"""Checks of a :class:`~dualpose.types.recording.Recording` before and after the static alignment of
``dualpose fuse`` (docs/fusion.md, "Checks on the input"; docs/refusals.md, "Inputs: samples, parameters, saved
states, set-ups").

Refused (:class:`dualpose.io.recording.RecordingError`, naming the recording): an IMU stream too short to hold a rest
period and some motion, a ``rest_duration_s`` as long as the recording, an accelerometer in units of g, and a
``gravity`` that points up (the specific force at rest, rotated to the world with the first-frame attitude, must point
opposite to gravity).  Doubted -- warned (:class:`dualpose.types.recording.RecordingWarning`) *and* returned as
:class:`~dualpose.types._inputs.Doubt` s, which :func:`dualpose.pipelines.fuse.run_fuse` reports under
``metrics["input_doubts"]``: IMU gaps longer than a few sample periods, an ``imu.update_rate`` that contradicts the
stamps, a gyroscope that reads like deg/s, and a gravity vector more than 10° off the measured vertical or of the
wrong magnitude.
"""

from __future__ import annotations

import warnings
from collections.abc import Callable

import numpy as np

from dualpose.estimation.state import ESKF_STATE
from dualpose.io.recording import RecordingError
from dualpose.types import Recording
from dualpose.types._inputs import (
    Doubt,
    accel_unit_problem,
    gravity_sigma_doubt,
    gyro_unit_doubt,
    rate_doubt,
    rest_gravity_sigma,
    rest_problem,
)  # fmt: skip
from dualpose.types.recording import RecordingWarning

__all__ = ["MIN_IMU_SAMPLES", "MIN_IMU_SECONDS", "check_before_fuse", "check_gravity_after_alignment", "warned"]

#: ``dualpose fuse`` needs a rest period (the static alignment) and then motion: at least this much IMU data
MIN_IMU_SAMPLES = 50
MIN_IMU_SECONDS = 1.0

#: the rest period the unit checks look at when the recording does not state one, s
_REST_S = 0.2


def check_before_fuse(run: Recording, at_rest: bool = True) -> list[Doubt]:
    """Refuse a recording too short to fuse, a rest period as long as it, an accelerometer in g; warn about and
    return the doubts: IMU gaps (:meth:`Recording.check_imu_gaps`), the stated IMU rate against the stamps, a
    gyroscope in deg/s over the rest period (only when ``at_rest``: a recording that starts at rest; a moving one
    checks its gyroscope against its camera, :func:`dualpose.types._inputs.gyro_rotation_doubt`)."""
    where = run.name or "recording"
    if len(run.t) < MIN_IMU_SAMPLES or run.duration < MIN_IMU_SECONDS:
        raise RecordingError(
            f"{where}: imu: {len(run.t)} samples over {run.duration:.3f} s; fusing needs at least "
            f"{MIN_IMU_SAMPLES} samples and {MIN_IMU_SECONDS:g} s (a rest period for the static alignment, then motion)"
        )
    problem = rest_problem(run.rest_seconds, run.duration, where)
    rest = run.t <= run.t[0] + (_REST_S if run.rest_seconds is None else run.rest_seconds)
    problem = problem or accel_unit_problem(run.accel[rest], run.gravity, where)
    if problem:
        raise RecordingError(problem)
    doubts = _warned(run.check_imu_gaps, "imu_gap")
    n = run.imu_noise
    gyro = gyro_unit_doubt(run.gyro[rest], n.gyroscope_noise_density, 1.0 / run.nominal_period(), where)
    return doubts + warned(rate_doubt(run.t, n.update_rate, where), gyro if at_rest else None)


def warned(*doubts: Doubt | None) -> list[Doubt]:
    """The doubts that are not None, each warned (:class:`RecordingWarning`) as it is returned."""
    out = [d for d in doubts if d is not None]
    for d in out:
        warnings.warn(d.message, RecordingWarning, stacklevel=3)
    return out


def check_gravity_after_alignment(run: Recording, x: np.ndarray) -> tuple[float, list[Doubt]]:
    """:meth:`Recording.check_gravity` with the start attitude ``q_wb`` of the error-state filter state ``x``
    (:data:`~dualpose.estimation.state.ESKF_STATE`), after the rule on the precision of the gravity direction the
    rest period measures (:func:`dualpose.types._inputs.gravity_sigma_doubt` on
    :func:`~dualpose.types._inputs.rest_gravity_sigma`: the spread of the samples, floored at the accelerometer's
    white noise).  Returns that σ (rad) and the doubts, each warned: a gravity that points up or a rest period that
    does not determine the vertical (σ above 5°) is a :class:`RecordingError`; a σ above 1° or a gravity vector
    more than 10° off the measured vertical is doubted."""
    where = run.name or "recording"
    rest = run.t <= run.t[0] + (_REST_S if run.rest_seconds is None else run.rest_seconds)
    n = run.imu_noise
    sigma = rest_gravity_sigma(run.accel[rest], n.accelerometer_noise_density, 1.0 / run.nominal_period())
    try:
        doubts = warned(gravity_sigma_doubt(sigma, f"{where}: rest period", f"the {int(rest.sum())} accelerometer "
                                            "samples at rest"))  # fmt: skip
        return sigma, doubts + _warned(lambda: run.check_gravity(ESKF_STATE.get(x, "quat")), "gravity")
    except ValueError as exc:
        raise RecordingError(str(exc)) from None


def _warned(check: Callable[[], object], code: str) -> list[Doubt]:
    """Run ``check``; each :class:`RecordingWarning` it gives is warned again and returned as a Doubt ``code``."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", RecordingWarning)
        check()
    out = []
    for w in caught:
        if issubclass(w.category, RecordingWarning):
            out.append(Doubt(code, str(w.message)))
        warnings.warn_explicit(w.message, w.category, w.filename, w.lineno)
    return out
