"""
Dual-quaternion algebra and ScLERP
==================================

A rigid transform is a unit dual quaternion ``[real xyzw, dual xyzw]`` with ``dual = ½ t
⊗ real`` (:doc:`/conventions`).  This example composes two poses, reads the screw of the
relative motion (Walker 1991 eqs. (8)–(12)), and interpolates between them with ScLERP,
the constant-screw path, against the naive path that interpolates the rotation (SLERP)
and the translation (linearly) separately.
"""

# %%
# Two poses and their composition
# -------------------------------
# A pose maps body coordinates to world coordinates, ``p_world = R p_body + t``.  The
# product ``a ⊗ b`` applies ``b`` first.
import matplotlib.pyplot as plt
import numpy as np

import dualpose as dp

start = dp.dualquat_from_qt(dp.quat_identity(), [0.0, 0.0, 0.0])
end = dp.dualquat_from_qt(
    dp.quat_from_rotvec([0.0, 0.0, np.pi * 0.75]), [2.0, 1.0, 0.5]
)
step = dp.dualquat_mul(dp.dualquat_inv(start), end)  # the motion from start to end
np.testing.assert_allclose(dp.dualquat_mul(start, step), end, atol=1e-15)
print("start ⊗ (start⁻¹ ⊗ end) == end")

# %%
# The screw of the motion
# -----------------------
# Every rigid motion is a rotation θ about a line (direction ``n`` through the point
# ``p``) combined with a translation ``d`` along it (Chasles).  ``screw_from_dualquat``
# returns ``(n, p, d, θ)``; ``p`` is the point of the axis closest to the origin.
n, p, d, theta = dp.screw_from_dualquat(step)
print(
    f"axis n = {np.round(n, 3)}, point p = {np.round(p, 3)} m, "
    f"distance d = {d:.3f} m, angle θ = {theta:.3f} rad"
)
np.testing.assert_allclose(
    dp.dualquat_from_screw(n, p, d, theta), dp.dualquat_canonical(step), atol=1e-12
)

# %%
# ScLERP against SLERP + linear translation
# -----------------------------------------
# ScLERP, ``start ⊗ (start⁻¹ ⊗ end)^τ``, moves along the screw at a constant rate: the
# body origin travels on a helix about the screw axis.  Interpolating rotation and
# translation separately moves the origin on a straight line, which is not the path of
# any constant motion.
tau = np.linspace(0.0, 1.0, 9)
path = dp.dualquat_sclerp(start, end, tau)  # (9, 8)
quats, origins = dp.qt_from_dualquat(path)  # (9, 4) xyzw, (9, 3) m
q_end, t_end = dp.qt_from_dualquat(end)
naive_q = dp.quat_slerp(dp.quat_identity(), q_end, tau)
naive_t = tau[:, None] * t_end

fig = plt.figure(figsize=(7, 5))
ax = fig.add_subplot(projection="3d")
axis_colors = ("tab:red", "tab:green", "tab:blue")
for q, t in zip(quats, origins, strict=True):
    for i, c in enumerate(axis_colors):
        ax.quiver(*t, *(0.35 * dp.matrix_from_quat(q)[:, i]), color=c, linewidth=1.2)
ax.plot(*origins.T, "k-o", ms=3, label="ScLERP (constant screw)")
ax.plot(*naive_t.T, "--", color="tab:gray", label="SLERP + linear translation")
line = p + np.outer(np.linspace(-0.5, 1.0, 2), n)
ax.plot(*line.T, ":", color="tab:purple", label="screw axis")
ax.set(
    xlabel="x [m]", ylabel="y [m]", zlabel="z [m]", title="Interpolating a rigid motion"
)
ax.legend(loc="upper left")
ax.set_box_aspect((1, 1, 0.6))
plt.show()

# %%
# Both paths reach the same pose; the orientations agree at every τ (ScLERP's rotation
# part is SLERP), only the positions differ.
print(
    "largest orientation difference [rad]:", float(dp.quat_angle(quats, naive_q).max())
)
print(
    "largest position difference [m]:",
    float(np.linalg.norm(origins - naive_t, axis=1).max()),
)
