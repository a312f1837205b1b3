"""Calibration-target recordings: the target-corner detection files (:mod:`~dualpose.io.target.detections`) and the
target-recording directories with the camera-IMU calibration JSON (:mod:`~dualpose.io.target.recording`)."""
