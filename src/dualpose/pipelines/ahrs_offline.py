"""The offline AHRS on a BROAD trial: the RTS smoother (:mod:`dualpose.estimation.ahrs.smoother`) and the scores of
the smoothed and the forward orientation with BROAD's metric; the job behind ``dualpose ahrs FILE --offline``
(docs/broad.md, "Offline (smoothed)").  :func:`broad_scores` also scores the forward filter of ``dualpose ahrs
FILE``."""

from __future__ import annotations

import numpy as np

from dualpose.estimation.ahrs.smoother import SmoothedOrientation, smooth_orientation
from dualpose.evaluation.orientation_errors import orientation_rmse
from dualpose.io.broad import BroadTrial

__all__ = ["broad_scores", "smooth_broad_trial"]


def broad_scores(quat: np.ndarray, trial: BroadTrial, *, use_mag: bool = True) -> dict[str, float] | None:
    """BROAD's total / heading / inclination RMSE (°) of ``quat`` (n, 4) xyzw IMU → ENU over the trial's movement
    samples (:meth:`~dualpose.evaluation.orientation_errors.OrientationRmse.as_dict`); 6D (``use_mag`` False)
    after one constant heading offset.  None when the trial has no reference on its movement samples."""
    if not bool(np.isfinite(trial.quat[trial.movement]).all(axis=1).any()):
        return None
    return dict(orientation_rmse(quat, trial.quat, trial.movement, fit_heading_offset=not use_mag).as_dict())


def smooth_broad_trial(
    trial: BroadTrial, *, use_mag: bool = True, mag_calibration: str | None = None
) -> tuple[SmoothedOrientation, dict[str, float] | None]:
    """Smooth one BROAD trial's orientation and score it.

    Parameters
    ----------
    trial : BroadTrial
        From :func:`dualpose.io.load_broad`; the samples before its first movement sample are the rest period
        (at least 10).
    use_mag : bool
        9D (True) or 6D (False).
    mag_calibration : "auto" or None
        The magnetometer self-calibration decision (``"auto"``), or None (default) for the raw field.

    Returns
    -------
    smoothed : SmoothedOrientation
    scores : dict or None
        BROAD's total / heading / inclination RMSE (°) over the movement samples of the smoothed orientation
        (``total_rmse_deg``, ... as :meth:`~dualpose.evaluation.orientation_errors.OrientationRmse.as_dict`) and of
        the forward filter (the same keys prefixed ``forward_``); 6D after one constant heading offset each.  None when
        the trial has no reference on its movement samples.
    """
    s = smooth_orientation(
        trial.gyr, trial.acc, trial.mag if use_mag else None, trial.rate, use_mag=use_mag,
        n_rest=max(trial.static_start, 10), mag_calibration=mag_calibration,
    )  # fmt: skip
    scores = broad_scores(s.quat, trial, use_mag=use_mag)
    if scores is None:
        return s, None
    fwd = broad_scores(s.forward.quat, trial, use_mag=use_mag)
    if fwd is not None:  # (the same trial's reference: present as for the smoothed scores)
        scores.update({f"forward_{k}": v for k, v in fwd.items()})
    return s, scores
