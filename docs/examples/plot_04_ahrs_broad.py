"""
Orientation from a real IMU: the AHRS on a BROAD trial
======================================================

:func:`~dualpose.estimation.ahrs.batch.estimate_orientation` runs dualpose's orientation
filter (gyroscope + accelerometer + magnetometer, with the gyroscope bias and the
magnetometer's lag estimated online) over a whole recording in one compiled pass.  Here
it runs on a trial of the BROAD benchmark (Laidig, Caruso, Cereatti & Seel 2021: a
smartphone-grade IMU with an optical reference) and is scored with BROAD's metric, the
RMSE of the orientation error split into heading and inclination.  The results over all
trials, and the comparison with VQF and Madgwick, are in :doc:`/broad`.

The BROAD files are not part of the repository: the example looks for a
``shared/data/broad`` folder beside the checkout (or beside one of its parent folders),
or in ``$DUALPOSE_BROAD_DIR``.  Without it, it runs on a simulated recording with rest
breaks instead and says so below.
"""

# %%
# The data
# --------
import os
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np

import dualpose
from dualpose.estimation.ahrs import estimate_orientation
from dualpose.evaluation.orientation_errors import (
    earth_error_quat,
    heading_inclination_errors,
    orientation_rmse,
)

TRIAL = "01_undisturbed_slow_rotation_A.mat"


def find_broad() -> Path | None:
    """``$DUALPOSE_BROAD_DIR``, else ``shared/data/broad`` beside the checkout."""
    checkout = Path(dualpose.__file__).resolve().parents[2]
    candidates = [
        folder / "shared" / "data" / "broad" for folder in (checkout, *checkout.parents)
    ]
    if "DUALPOSE_BROAD_DIR" in os.environ:
        candidates = [Path(os.environ["DUALPOSE_BROAD_DIR"])]
    return next((c for c in candidates if (c / TRIAL).is_file()), None)


broad = find_broad()
if broad is not None:
    from dualpose.io import load_broad

    trial = load_broad(broad / TRIAL)
    name, rate, gyr, acc, mag = trial.name, trial.rate, trial.gyr, trial.acc, trial.mag
    reference, scored, n_rest = trial.quat, trial.movement, None
    print(
        f"BROAD trial {name}: {len(gyr)} samples at {rate:.0f} Hz "
        f"({len(gyr) / rate:.0f} s)"
    )
else:
    from dualpose.sim.rest_breaks import rest_break_recording

    sim = rest_break_recording(seed=0)
    name, rate, gyr, acc, mag = (
        "simulated rotation with rest breaks",
        sim.rate,
        sim.gyr,
        sim.acc,
        sim.mag,
    )
    reference, scored, n_rest = sim.quat, sim.scored, sim.n_rest
    print(
        "NOTE: the BROAD data was not found (see above); "
        "this page shows a simulated recording instead."
    )
    print(f"{name}: {len(gyr)} samples at {rate:.0f} Hz")

# %%
# 9D and 6D estimates
# -------------------
# 6D (no magnetometer) cannot know the heading; BROAD scores it after removing the best
# constant heading offset.
est9 = estimate_orientation(gyr, acc, mag, rate, n_rest=n_rest)
est6 = estimate_orientation(gyr, acc, None, rate, use_mag=False, n_rest=n_rest)
rmse9 = orientation_rmse(est9.quat, reference, scored)
rmse6 = orientation_rmse(est6.quat, reference, scored, fit_heading_offset=True)
for label, r in (("9D", rmse9), ("6D", rmse6)):
    print(
        f"{label}: total {r.total_rmse_deg:.2f}°, heading {r.heading_rmse_deg:.2f}°, "
        f"inclination {r.inclination_rmse_deg:.2f}° over {r.scored_samples} samples"
    )

# %%
# Errors over time
# ----------------
# The earth-frame error ``e = q_est ⊗ q_ref*`` splits into a rotation about the vertical
# (heading) and a tilt (inclination).  Samples without a reference (NaN) are left out.
ok = np.isfinite(reference).all(axis=1)
t = np.arange(len(gyr)) / rate
_, heading, inclination = heading_inclination_errors(
    earth_error_quat(est9.quat[ok], reference[ok])
)
fig, axes = plt.subplots(2, 1, figsize=(8, 5), sharex=True)
axes[0].plot(t[ok], np.rad2deg(heading), lw=0.8)
axes[0].set(ylabel="heading error [deg]", title=f"9D AHRS on {name}")
axes[1].plot(t[ok], np.rad2deg(inclination), lw=0.8, color="tab:orange")
axes[1].set(ylabel="inclination error [deg]", xlabel="time [s]")
for ax in axes:
    ax.grid(alpha=0.3)
fig.tight_layout()
plt.show()

# %%
# The estimated gyroscope bias
# ----------------------------
fig, ax = plt.subplots(figsize=(8, 3))
ax.plot(t, np.rad2deg(est9.gyroscope_bias), lw=0.8)
ax.set(xlabel="time [s]", ylabel="bias [deg/s]", title="Gyroscope bias (x, y, z)")
ax.legend(["x", "y", "z"])
fig.tight_layout()
plt.show()
