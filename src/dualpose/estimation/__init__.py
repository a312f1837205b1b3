"""Camera-IMU pose tracking (Hol 2008; Solà 2017).

Submodules are imported explicitly (``from dualpose.fusion import sim, eskf``); nothing heavy loads here.
Conventions: the earth (world) frame ``w``/``e``, the IMU body frame ``b``, the camera frame ``c`` (z along the
optical axis, x right, y down).  Orientations ``q_wb`` are ``(..., 4)`` xyzw quaternions rotating body vectors into
the world frame (active, ``v_w = q v_b q*``); Hol's ``q^{be}`` is its conjugate.
"""
