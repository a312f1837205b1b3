"""
Hand–eye calibration (Daniilidis 1999)
======================================

A camera rigidly mounted on a robot's gripper sees a fixed target.  With the gripper
poses ``G_i`` (gripper → base, from the robot) and the target poses ``C_i`` (target →
camera, from the images), the relative motions ``A = G_i⁻¹ G_j`` and ``B = C_i C_j⁻¹``
satisfy ``A X = X B`` for the unknown camera → gripper transform ``X``.
:func:`~dualpose.registration.hand_eye.calibrate_hand_eye` solves it with Daniilidis's
dual-quaternion SVD, checks the screw congruence of every pair and reports a covariance.
Calibration of recorded pose streams with an unknown time offset: :doc:`/hand-eye`.
"""

# %%
# Simulated stations
# ------------------
import warnings

import matplotlib.pyplot as plt
import numpy as np

import dualpose as dp
import dualpose.registration as reg

rng = np.random.default_rng(1999)
X_true = dp.dualquat_from_qt(
    dp.quat_from_rotvec([0.1, -1.4, 0.2]), [0.03, 0.05, 0.12]
)  # camera -> gripper, m
W = dp.dualquat_from_qt(dp.quat_identity(), [0.8, 0.0, 0.0])  # target -> base


def stations(n: int, pixel_noise: bool = True) -> tuple[np.ndarray, np.ndarray]:
    """``n`` gripper poses around the target and the target poses the camera sees."""
    G = dp.dualquat_from_qt(
        dp.quat_from_rotvec(0.5 * rng.normal(size=(n, 3))),
        [0.5, 0.0, 0.4] + 0.15 * rng.normal(size=(n, 3)),
    )
    C = dp.dualquat_mul(
        dp.dualquat_inv(dp.dualquat_mul(G, X_true)), W
    )  # target -> camera
    if pixel_noise:  # 0.1° and 1 mm of measurement noise on the target pose
        noise = np.concatenate(
            [
                np.deg2rad(0.1) * rng.normal(size=(n, 3)),
                0.001 * rng.normal(size=(n, 3)),
            ],
            axis=1,
        )
        C = dp.dualquat_mul(dp.dualquat_from_twist(noise), C)
    return G, C


# The screw congruence check compares each pair's rotation angle and translation along
# the axis; its tolerances are set from the measurement noise (1° and 2 cm: noise of
# 0.1° at a lever arm of ~1 m, on both ends of a motion).
TOLERANCES = {"angle_tol": np.deg2rad(1.0), "distance_tol": 0.02}
G, C = stations(10)
A, B = reg.hand_eye_motions(G, C, pairs="all")
result = reg.calibrate_hand_eye(A, B, **TOLERANCES)
rot_err = np.rad2deg(dp.quat_angle(result.quat, dp.qt_from_dualquat(X_true)[0]))
pos_err = np.linalg.norm(result.translation - dp.qt_from_dualquat(X_true)[1]) * 1000
print(
    f"10 stations, {len(A)} motion pairs: rotation error {rot_err:.3f}°, "
    f"translation error {pos_err:.2f} mm"
)
sigma = np.sqrt(np.diag(result.covariance))
print(
    f"reported 1σ: rotation {np.rad2deg(np.linalg.norm(sigma[:3])):.3f}°, "
    f"translation {np.linalg.norm(sigma[3:]) * 1000:.2f} mm"
)

# %%
# More stations, smaller errors
# -----------------------------
# Now and then a pair with a small rotation fails the congruence check by chance (its
# screw axis, and so the translation along it, is poorly determined); the sweep keeps
# such pairs and silences the warning.
counts = np.array([3, 5, 8, 12, 20])
rot, pos = [], []
warnings.simplefilter("ignore", reg.HandEyeWarning)
for n in counts:
    r, p = [], []
    for _ in range(10):
        A, B = reg.hand_eye_motions(*stations(n), pairs="all")
        res = reg.calibrate_hand_eye(A, B, **TOLERANCES)
        q_true, t_true = dp.qt_from_dualquat(X_true)
        r.append(np.rad2deg(dp.quat_angle(res.quat, q_true)))
        p.append(np.linalg.norm(res.translation - t_true) * 1000)
    rot.append(np.median(r))
    pos.append(np.median(p))

fig, ax = plt.subplots(figsize=(7, 4))
ax.loglog(counts, rot, "o-", label="rotation [deg]")
ax.loglog(counts, pos, "s-", label="translation [mm]")
ax.set(
    xlabel="stations",
    ylabel="median error (10 draws)",
    title="Hand–eye error against the number of stations",
)
ax.set_xticks(counts, [str(c) for c in counts])
ax.xaxis.set_minor_locator(plt.NullLocator())
ax.legend()
ax.grid(True, which="both", alpha=0.3)
plt.show()
