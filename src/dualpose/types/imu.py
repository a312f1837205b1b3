"""IMU sensor description: noise densities and random walks (Kalibr ``imu.yaml`` conventions).

IMU model (continuous-time densities; Hol 2008 eq. 1, 2 with Kalibr's parameter names)::

    gyro  = ω_b + b_g + n_g,   n_g ~ N(0, σ_g² / Δt),  ḃ_g = σ_bg w
    accel = R_wbᵀ (a_w − g_w) + b_a + n_a,   n_a ~ N(0, σ_a² / Δt),  ḃ_a = σ_ba w
"""

from __future__ import annotations

import math
from dataclasses import dataclass

__all__ = ["ImuNoise", "STANDARD_GRAVITY"]

STANDARD_GRAVITY = 9.81


@dataclass(frozen=True)
class ImuNoise:
    """IMU noise in Kalibr's ``imu.yaml`` terms (continuous-time densities); defaults resemble an Xsens MTx.

    Attributes
    ----------
    gyroscope_noise_density : float
        rad/s/√Hz (default 1.745e-3 = 0.1 °/s/√Hz).
    gyroscope_random_walk : float
        rad/s²/√Hz, bias random walk.
    accelerometer_noise_density : float
        m/s²/√Hz.
    accelerometer_random_walk : float
        m/s³/√Hz.
    gyroscope_initial_bias_sigma, accelerometer_initial_bias_sigma : float
        Standard deviation of the turn-on bias drawn per run (rad/s, m/s²).
    update_rate : float
        Hz.
    gyroscope_scale_sigma, accelerometer_scale_sigma : float
        Relative uncertainty ε of the gyroscope's and the accelerometer's scale factors and axis alignment (a model
        error proportional to the signal; not in Kalibr's model, default 0).  The ESKF and Hol22 add
        ``ε² |ω|² · 1 s`` to the gyroscope's and ``ε_a² |f|² · 1 s`` to the accelerometer's noise density (rad²/s,
        m²/s³), as the AHRS's ``gyro_scale_sigma`` (:class:`dualpose.estimation.ahrs.AhrsConfig`).
    """

    gyroscope_noise_density: float = math.radians(0.1)
    gyroscope_random_walk: float = 4.0e-5
    accelerometer_noise_density: float = 2.0e-3
    accelerometer_random_walk: float = 4.0e-4
    gyroscope_initial_bias_sigma: float = math.radians(0.5)
    accelerometer_initial_bias_sigma: float = 0.05
    update_rate: float = 100.0
    gyroscope_scale_sigma: float = 0.0
    accelerometer_scale_sigma: float = 0.0

    def scaled(self, factor: float) -> ImuNoise:
        """All noise terms (not the rate) multiplied by ``factor`` (``0`` gives a noise-free IMU)."""
        return ImuNoise(
            self.gyroscope_noise_density * factor,
            self.gyroscope_random_walk * factor,
            self.accelerometer_noise_density * factor,
            self.accelerometer_random_walk * factor,
            self.gyroscope_initial_bias_sigma * factor,
            self.accelerometer_initial_bias_sigma * factor,
            self.update_rate,
            self.gyroscope_scale_sigma * factor,
            self.accelerometer_scale_sigma * factor,
        )
