"""
Trajectory evaluation: ATE, RPE and alignment
=============================================

:func:`~dualpose.evaluation.metrics.evaluate` scores an estimated trajectory against a
reference the way ``evo`` does (and agrees with it, :doc:`/metrics`): associate the
stamps, align the estimate (SE(3), Sim(3), scale, origin or none), then the absolute
trajectory error (ATE) per pose and the relative pose error (RPE) over a step. The same
is ``dualpose eval REFERENCE ESTIMATE`` on TUM, KITTI or EuRoC files.

The estimate here is made to look like monocular visual odometry: the reference seen in
another frame, at 80 % of the scale, with a slow drift and noise.
"""

# %%
# A reference and a drifting estimate
# -----------------------------------
import tempfile
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np

import dualpose as dp
from dualpose import sim
from dualpose.evaluation.metrics import evaluate
from dualpose.io import Trajectory, read_tum, write_tum

run = sim.simulate_eight(0)
stamps = run.t[::4]  # 25 Hz, seconds
p_ref, q_ref = run.truth["position"][::4], run.truth["quat"][::4]
reference = Trajectory(stamps, p_ref, q_ref, name="reference")

rng = np.random.default_rng(7)
q_frame = dp.quat_from_rotvec(
    [0.0, 0.0, 0.6]
)  # the estimate's world frame is another one
drift = np.cumsum(0.0005 * rng.normal(size=p_ref.shape), axis=0)
p_est = 0.8 * dp.quat_rotate(q_frame, p_ref + drift) + [1.0, -2.0, 0.3]
q_est = dp.quat_mul(q_frame, q_ref)
estimate = Trajectory(
    stamps + 0.002, p_est + 0.002 * rng.normal(size=p_est.shape), q_est, name="estimate"
)

# %%
# Three alignments
# ----------------
# Without alignment the frames differ and the numbers mean nothing; SE(3) removes the
# frame; Sim(3) also the scale.
results = {
    align: evaluate(reference, estimate, align=align)
    for align in ("none", "se3", "sim3")
}
for align, ev in results.items():
    print(
        f"{align:>5}: ATE RMSE {np.sqrt(np.mean(ev.ate**2)):.3f} m, "
        f"RPE RMSE {np.sqrt(np.mean(ev.rpe_translation**2)):.4f} m per frame"
    )
print(
    f"Sim(3) scale found: {results['sim3'].alignment.scale:.4f} "
    "(the estimate is at 0.8 of the scale: 1/0.8 = 1.25)"
)

fig, axes = plt.subplots(1, 2, figsize=(10, 4))
ax = axes[0]
ax.plot(*reference.positions[:, ::2].T, "k", lw=2, label="reference")
for align in ("se3", "sim3"):
    ax.plot(
        *results[align].positions_est[:, ::2].T,
        lw=1,
        label=f"estimate, {align} aligned",
    )
ax.set(
    xlabel="x [m]", ylabel="z [m]", aspect="equal", title="The eight in the x–z plane"
)
ax.legend(fontsize=8)
ax = axes[1]
for align in ("se3", "sim3"):
    ev = results[align]
    ax.plot(ev.stamps - ev.stamps[0], ev.ate * 100, lw=1, label=align)
ax.set(xlabel="time [s]", ylabel="ATE [cm]", title="Absolute trajectory error")
ax.legend()
fig.tight_layout()
plt.show()

# %%
# Through TUM files, as ``dualpose eval`` reads them
# --------------------------------------------------
# ``write_tum`` never overwrites a file unless asked (``overwrite=True``).
with tempfile.TemporaryDirectory() as tmp:
    write_tum(Path(tmp) / "ref.txt", reference)
    write_tum(Path(tmp) / "est.txt", estimate)
    ev = evaluate(
        read_tum(Path(tmp) / "ref.txt"), read_tum(Path(tmp) / "est.txt"), align="sim3"
    )
print(
    f"from files: ATE RMSE {np.sqrt(np.mean(ev.ate**2)):.3f} m "
    "(dualpose eval ref.txt est.txt --align sim3 prints the same)"
)
