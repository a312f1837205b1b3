"""
Batches and streams
===================

Every function of the algebra is a NumPy gufunc: it broadcasts over leading axes, writes
into ``out=`` and takes any strides, so a million poses are one call and no Python loop.
The filters come in both shapes too: a whole-recording batch call, and a stream fed one
sample (or one block) at a time whose state can be saved and restored, giving the
batch's numbers to the last bit.  This example shows both with the AHRS
(:class:`~dualpose.estimation.ahrs.stream.AhrsStream`); the camera–IMU filters have the
same streams (:class:`~dualpose.estimation.eskf.EskfStream`, :doc:`/fusion`).
"""

# %%
# A million poses in one call
# ---------------------------
import time

import matplotlib.pyplot as plt
import numpy as np

import dualpose as dp
from dualpose.estimation.ahrs import AhrsStream, estimate_orientation
from dualpose.sim.rest_breaks import rest_break_recording

rng = np.random.default_rng(8)
n = 1_000_000
poses = dp.dualquat_from_qt(
    dp.quat_from_rotvec(rng.normal(size=(n, 3))), rng.normal(size=(n, 3))
)  # (n, 8)
points = rng.normal(size=(n, 3))  # (n, 3)
world = np.empty((n, 3))
start = time.perf_counter()
dp.dualquat_transform(
    poses, points, out=world
)  # one pose per point, into a preallocated array
print(f"{n:,} point transforms: {(time.perf_counter() - start) * 1e3:.1f} ms")

# Broadcasting: one pose for all points, or every pose composed with one offset
offset = dp.dualquat_from_qt(
    dp.quat_from_rotvec([0.0, 0.0, 0.1]), [0.0, 0.0, 1.0]
)  # (8,)
moved = dp.dualquat_mul(poses, offset)  # (n, 8) @ (8,) -> (n, 8)
print("shapes:", poses.shape, "⊗", offset.shape, "->", moved.shape)

# %%
# The AHRS as a batch and as a stream
# -----------------------------------
# A simulated recording with rest breaks (100 Hz, 135 s).  The stream is fed in blocks
# of one second, saved to a plain dict after the first half and restored into a new
# stream, as a process that restarts would.
rec = rest_break_recording(seed=1)
batch = estimate_orientation(rec.gyr, rec.acc, rec.mag, rec.rate, n_rest=rec.n_rest)

t = np.arange(len(rec.gyr)) / rec.rate
stream = AhrsStream(rec.rate, n_rest=rec.n_rest)
quats = []
half = len(t) // 2
for first in range(0, len(t), 100):
    if (
        first == (half // 100) * 100
    ):  # save, and continue in a stream restored from the saved state
        stream = AhrsStream.from_state(stream.state_dict())
    block = slice(first, first + 100)
    q, _ = stream.update_batch(t[block], rec.gyr[block], rec.acc[block], rec.mag[block])
    quats.append(q)
quats = np.concatenate(quats)
print("stream == batch, bit for bit:", np.array_equal(quats, batch.quat))

# %%
# One sample at a time
# --------------------
# ``update_imu`` returns the orientation after each sample; 3 000 calls take a fraction
# of a second.
stream = AhrsStream(rec.rate, n_rest=rec.n_rest)
start = time.perf_counter()
single = np.array(
    [stream.update_imu(t[k], rec.gyr[k], rec.acc[k], rec.mag[k]) for k in range(3000)]
)
per_sample = (time.perf_counter() - start) / 3000
print(
    f"{per_sample * 1e6:.1f} µs per sample; "
    f"equal to the batch: {np.array_equal(single, batch.quat[:3000])}"
)

error = np.rad2deg(dp.quat_angle(batch.quat, rec.quat))
fig, ax = plt.subplots(figsize=(8, 3))
ax.plot(t, error, lw=0.8)
for b0, b1 in rec.breaks:
    ax.axvspan(t[b0], t[b1 - 1], color="tab:green", alpha=0.15)
ax.set(
    xlabel="time [s]",
    ylabel="orientation error [deg]",
    title="AHRS (batch = stream) on a simulated recording; rest breaks shaded",
)
fig.tight_layout()
plt.show()
