"""The simulator's feature-track mode: exact normalised projections of the true landmarks, track ids that follow a
landmark while it stays visible."""

from __future__ import annotations

import numpy as np

from dualpose import sim


def test_tracks_are_projections_of_the_landmarks() -> None:
    run, rec = sim.simulate_tracks(sim.random_motion(3, duration=1.0), seed=3, feature_sigma=0.0, n_landmarks=60)
    tr = rec.tracks
    lm = rec.meta["landmark_ids"]
    kin = run.motion.kinematics(run.frames.t_true)
    for k in (0, len(tr) // 2, len(tr) - 1):
        a, b = tr.offsets[k], tr.offsets[k + 1]
        pc = sim.camera_points(kin["quat"][k], kin["position"][k], run.q_bc, run.p_bc, run.landmarks[lm[a:b]])
        np.testing.assert_allclose(tr.uv[a:b], pc[:, :2] / pc[:, 2:3], rtol=0, atol=1e-12)
        assert len(np.unique(tr.track_id[a:b])) == b - a
    # one landmark per track id, and a track's frames are consecutive
    for tid in np.unique(tr.track_id)[:20]:
        rows = np.flatnonzero(tr.track_id == tid)
        assert len(np.unique(lm[rows])) == 1
        frames = np.searchsorted(tr.offsets, rows, side="right") - 1
        assert np.all(np.diff(frames) == 1)
    assert rec.tracks.t.shape == run.frames.t.shape and np.mean(tr.counts) > 10
