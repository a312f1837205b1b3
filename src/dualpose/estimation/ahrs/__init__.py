"""Orientation-only error-state filter (AHRS): gyroscope + accelerometer (+ magnetometer), compiled kernel.

The error-state filter of :mod:`dualpose.estimation.eskf` reduced to orientation and gyroscope bias:

* nominal state ``q`` (4,) xyzw rotating IMU (body) vectors into the earth frame (ENU, x = magnetic east,
  y = magnetic north, z = up), and the gyroscope bias ``b`` (3,) rad/s;
* error state ``δx = [δθ, δb]`` (6,) with a **global** 3-parameter attitude error ``q = Exp(δθ) ⊗ q̂``: ``δθ_z``
  is the heading error and ``(δθ_x, δθ_y)`` the inclination error, so the two are separated by construction;
* predict with the gyroscope as input (Solà 2017 §5 with the global error: ``δθ̇ = −R δb + R n_g``);
* measurements are earth-frame averages: the specific force ``a`` and the field ``m`` of every sample are rotated into
  the estimated earth frame with that sample's estimate; the field is averaged over the last ``window`` seconds (default
  3 s, a boxcar), the specific force is low-passed by a 2nd-order Butterworth with DC group delay ``τ = window / 2``
  (the discretisation of VQF's inertial-frame accelerometer filter, Laidig & Seel 2023); an update is made every
  ``update_interval`` (0.1 s). That low-pass has the boxcar's delay (T / 2) and the boxcar's noise-equivalent bandwidth
  (1 / (2T)), so it averages white noise as much, but its response to a linear acceleration oscillating at f falls as
  ``(f_c / f)²`` (``f_c = √2 / (2π τ)``) instead of the boxcar's ``1 / (π f T)``: in the earth frame the mean linear
  acceleration of a body whose velocity stays bounded is Δv / T over a boxcar, which the low-pass attenuates further.
  Averaging also removes sensor noise and fast tilt-coupled heading errors. The window's vectors and the low-pass state
  are stored in the *uncorrected* frame (``C⁻¹ R̂ v`` with ``C`` the product of all corrections applied so far; both are
  linear in the samples), so every correction rotates all past samples at once (current-frame value ``= C · stored``).
  Consecutive updates share samples: each update's noise is multiplied by the overlap ``window / update_interval``;
* accelerometer update: the horizontal components of the mean earth-frame specific force must vanish (2-D
  measurement ``y = [mean R̂ a]_{x,y}``, ``H = [[0, −g, 0, 0₃], [g, 0, 0, 0₃]]``).  It carries no heading
  information and its gain row for ``δθ_z`` is zeroed;
* magnetometer update (9D), **heading only**: ``y = atan2(m̄_x, m̄_y)`` of the mean earth-frame field (the heading of
  its horizontal projection, 0 = magnetic north), ``H = [0, 0, 1, 0₃]``, gain rows for ``δθ_x, δθ_y`` zeroed.  A
  magnetic disturbance therefore cannot tilt the estimate: it can only rotate it about the vertical, which is the
  one thing the magnetometer is needed for (the full 3-D field model would let a disturbed field pull
  inclination, which the accelerometer measures better).  The price is that the field's own tilt information is
  unused, which costs little because the accelerometer dominates inclination;
* adaptive rejection (innovation-based): each update's noise is inflated by a lower bound of the disturbance
  present -- the running mean square, over ``acc_motion_time`` (default ``window / 2``), of
  ``(| |ā| − g | − 2δg)₊`` for the accelerometer (the mean linear acceleration has at least that magnitude once the
  sensor's own error δ, ``acc_scale_sigma``, is allowed for; averaged because it is one realisation along the
  vertical of what the update needs as a variance along the horizontal axes; its direction error ``(δg)² / 3``
  per axis is part of the noise too), the
  window mean of ``(|m| − m₀)² + (m₀ Δdip)²`` for the magnetometer (change of the field's magnitude and dip from the
  reference measured at rest) -- and the accelerometer noise additionally gets an innovation-based (Sage-Husa /
  Mehra) estimate of the unmodelled acceleration's 2×2 covariance in the horizontal plane (time constant
  ``adapt_time``; ``acc_adapt_matrix``), held while the rest detector reports rest and fading out of the noise
  there as the low-pass's memory of the motion (``acc_adapt_rest_hold``).  Every innovation is
  χ²-gated (NIS above the ``gate_probability`` quantile is rejected; after ``gate_release`` seconds of
  uninterrupted rejection the gate re-opens and stays open until an innovation fits again, so that the filter
  re-acquires instead of locking itself out);
* covariance updates in Joseph form (valid for the zeroed, sub-optimal gains) followed by the reset Jacobian.
* magnetometer–gyroscope time offset, strictly causal by default: the field measured at ``t`` is the field at
  ``t − τ``, so it is rotated into the earth frame with the orientation at ``t − τ̂``,
  ``R̂(t) Exp(−∫_{t−τ̂}^{t} (ω − b) dt)`` from the gyroscope samples already seen; ``τ̂`` is estimated online inside
  the filter from the kinematic residual ``dm/dt + ω(t − τ) × (m − h) = 0`` of a static field with a hard-iron term
  ``h`` on causally filtered data (running sufficient statistics per candidate ``τ`` on a ±30 ms grid, ``h`` in
  closed form; ``src/native/estimation/ahrs_mag_lag.hpp``, docs/broad.md "Magnetometer–gyroscope time offset").  In
  fast rotation a lag τ turns the measured field by ``ω τ`` (at 5 rad/s and 11 ms: 3°).  The whole-recording
  (offline, not causal) estimate of :mod:`dualpose.calibration.sensor_time_offset` remains an option;
* rest detection with a gyroscope-bias update (strictly causal, in the same per-sample step): when the variances
  of the gyroscope and the accelerometer over the trailing ``rest_window`` (1.5 s) are both within ``rest_margin²``
  (9) times their white-noise variance measured at rest, the window's mean rate measures the bias (``H = [0, I]``,
  noise ``σ_g² / N`` times the window overlap, plus an error common to the whole quiet spell, ``rest_bias_sigma``
  (0.02 °/s: a "still" object's residual rotation, the bias at rest vs in motion), so a spell's information
  saturates; χ²(3)-gated without release; ``src/native/estimation/ahrs_rest.hpp``, docs/broad.md, "Rest detector
  and bias update");
* impulse clipping of the accelerometer: a sample of the earth-frame specific force enters the low-pass at most
  ``acc_clip`` (5) running RMS of its change from the low-pass's last output away from it, so a tap or shock
  (milliseconds, tens of g) cannot tilt the filtered vector while hand motion passes (docs/broad.md, "Twelve
  trials");
* causal rest period: inside the rest period (before its statistics are complete) the output is the orientation of
  the running mean specific force and field of the samples so far; at its last sample the filter is initialised from
  the rest statistics and run over the rest samples (all in the past by then), so no output depends on a later
  sample;
* optional magnetometer self-calibration (``mag_calibration="auto"``; hard iron / per-axis scale / symmetric soft
  iron) from the recording's own field samples, applied only when objective criteria say the data support it
  (orientation coverage, well-determined parameters, the field-magnitude spread in excess of the noise at least halved;
  :mod:`dualpose.calibration.magnetometer`); otherwise the raw field is used.  It runs before the time-offset
  estimate and the rest statistics (and, being fitted to the whole recording, is not causal).

Noise is set on principle, never per trial: white-noise levels of the three sensors are estimated from the rest period
at the start of the recording (robustly: median absolute deviation); the bias random walk and the relative gyroscope
scale-factor / misalignment uncertainty (0.5 %, calibrated-MEMS class; rate-proportional process noise) are fixed
sensor-class values; the window (3 s; the accelerometer low-pass's delay is half of it) and adaptation time (2 windows)
are motion-class choices for hand-held motion. The same values are used for every recording. Initialisation: the
gyroscope bias is the median rate over the rest period, the orientation comes from the rest period's median specific
force (inclination) and magnetic field (heading; 6D: the body x axis projected on the horizontal is east), and the
field's magnitude and dip at rest are the magnetometer's reference. In 6D the earth frame's heading is defined by that
initial orientation, so the initial heading uncertainty is small by definition (a huge value would only feed spurious
cross-covariances into the linearisation).
"""

from dualpose.estimation.ahrs import batch, config, estimator, smoother, stream
from dualpose.estimation.ahrs.batch import *  # noqa: F403
from dualpose.estimation.ahrs.config import *  # noqa: F403
from dualpose.estimation.ahrs.estimator import *  # noqa: F403
from dualpose.estimation.ahrs.smoother import *  # noqa: F403
from dualpose.estimation.ahrs.stream import *  # noqa: F403

__all__ = [*config.__all__, *batch.__all__, *estimator.__all__, *stream.__all__, *smoother.__all__]
