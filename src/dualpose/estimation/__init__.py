"""State estimation for camera-IMU and IMU-only pose tracking (Hol 2008; Solà 2017), behind one interface.

* :mod:`~dualpose.estimation.interface`: :class:`Estimator` (``propagate``, ``update``, ``state``, ``covariance``,
  named blocks) and the measurements it takes; :mod:`~dualpose.estimation.state`: every state layout, by name.
* :mod:`~dualpose.estimation.eskf` (error-state EKF, the recommended camera-IMU filter),
  :mod:`~dualpose.estimation.hol22` (Hol's 22-state EKF), and the orientation-only filter in its own package
  :mod:`~dualpose.estimation.ahrs`: ``config`` (noise, tuning, rest statistics, set-up), ``batch`` (the
  whole-recording, real-time estimator ``estimate_orientation``), ``stream`` (the same filter one sample at a time,
  bit for bit equal, with a savable state), ``smoother`` (its offline RTS smoother) and ``estimator`` (the filter
  behind the :class:`Estimator` interface); the package re-exports all of them.  ``eskf.EskfStream`` and
  ``hol22.Hol22Stream``: the camera-IMU filters streaming, bit for bit their batch ``run``.
* :mod:`~dualpose.estimation.smoother` (RTS), :mod:`~dualpose.estimation.initialization` (static alignment + PnP
  start), :mod:`~dualpose.estimation.consistency` (NEES), :mod:`~dualpose.estimation.models` (measurement models).

Submodules are imported explicitly (``from dualpose.estimation import eskf``); nothing heavy loads here.
Conventions: the earth (world) frame ``w``/``e``, the IMU body frame ``b``, the camera frame ``c`` (z along the
optical axis, x right, y down).  Orientations ``q_wb`` are ``(..., 4)`` xyzw quaternions rotating body vectors into
the world frame (active, ``v_w = q v_b q*``); Hol's ``q^{be}`` is its conjugate.
"""
