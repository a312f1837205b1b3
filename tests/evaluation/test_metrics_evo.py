"""The metrics equal evo's (test-only dependency) on the TUM / EuRoC pairs in ../shared/data/tum.

evo is driven through its library API exactly as ``evo_ape`` / ``evo_rpe`` do: ``sync.associate_trajectories``,
``PoseTrajectory3D.align(correct_scale=...)``, ``metrics.APE`` / ``metrics.RPE``.  The target is 1e-6 m
(docs/metrics.md); the observed differences are ~1e-15 (rounding), so the tests hold to 1e-9 m / 1e-9 degrees.
"""

from __future__ import annotations

import copy
from pathlib import Path

import numpy as np
import pytest

from dualpose.evaluation.metrics import associate, evaluate, rpe_pairs
from dualpose.io import read_trajectory
from realdata import data_dir

evo_metrics = pytest.importorskip("evo.core.metrics")
evo_sync = pytest.importorskip("evo.core.sync")
evo_filters = pytest.importorskip("evo.core.filters")
evo_files = pytest.importorskip("evo.tools.file_interface")

DATA = data_dir("tum")
PAIRS = {
    "fr2_desk": ("fr2_desk_groundtruth.txt", "fr2_desk_ORB.txt"),
    "V102": ("V102_groundtruth.csv", "V102.txt"),
}
STATS = ("rmse", "mean", "median", "std", "min", "max", "sse")
TOL = 1e-9


def _evo_read(path: Path):
    if path.suffix == ".csv":
        return evo_files.read_euroc_csv_trajectory(str(path))
    return evo_files.read_tum_trajectory_file(str(path))


@pytest.fixture(scope="module")
def loaded():
    if not DATA.is_dir():
        pytest.skip(f"data directory {DATA} missing")
    out = {}
    for key, (ref, est) in PAIRS.items():
        out[key] = (
            read_trajectory(DATA / ref),
            read_trajectory(DATA / est),
            _evo_read(DATA / ref),
            _evo_read(DATA / est),
        )
    return out


def _evo_pipeline(evo_ref, evo_est, align: str, max_diff: float = 0.01, offset: float = 0.0):
    ref, est = evo_sync.associate_trajectories(
        copy.deepcopy(evo_ref), copy.deepcopy(evo_est), max_diff=max_diff, offset_2=offset
    )
    params = None
    if align != "none":
        params = est.align(ref, correct_scale=align == "sim3")
    return ref, est, params


def _evo_stats(metric, data) -> dict:
    metric.process_data(data)
    return metric.get_all_statistics()


def _assert_stats(ours, theirs: dict, what: str) -> None:
    d = ours.as_dict()
    for k in STATS:
        tol = TOL * max(1.0, abs(theirs[k])) if k == "sse" else TOL
        assert abs(d[k] - theirs[k]) <= tol, f"{what} {k}: dualpose {d[k]!r} evo {theirs[k]!r}"


@pytest.mark.parametrize("align", ["none", "se3", "sim3"])
@pytest.mark.parametrize("pair", sorted(PAIRS))
def test_ate_orientation_and_rpe_equal_evo(loaded, pair, align):
    ref, est, evo_ref, evo_est = loaded[pair]
    r, e, params = _evo_pipeline(evo_ref, evo_est, align)
    ev = evaluate(ref, est, align=align, rpe_delta=1, rpe_unit="frames")
    # association: the same poses
    np.testing.assert_array_equal(ev.stamps, r.timestamps)
    np.testing.assert_array_equal(est.stamps[ev.idx_est], e.timestamps)
    # alignment: the same transform
    if params is not None:
        rot, trans, scale = params
        np.testing.assert_allclose(ev.alignment.rotation, rot, rtol=0, atol=1e-12)
        np.testing.assert_allclose(ev.alignment.translation, trans, rtol=0, atol=1e-12)
        assert abs(ev.alignment.scale - scale) <= 1e-12
    np.testing.assert_allclose(ev.positions_est, e.positions_xyz, rtol=0, atol=TOL)
    # ATE (translation part), orientation (rotation angle in degrees), RPE for delta = 1 frame
    _assert_stats(ev.ate_stats, _evo_stats(evo_metrics.APE(evo_metrics.PoseRelation.translation_part), (r, e)), "ATE")
    deg = evo_metrics.PoseRelation.rotation_angle_deg
    _assert_stats(ev.orientation_stats, _evo_stats(evo_metrics.APE(deg), (r, e)), "orientation")
    rpe_t = _evo_stats(evo_metrics.RPE(evo_metrics.PoseRelation.translation_part, 1, evo_metrics.Unit.frames), (r, e))
    _assert_stats(ev.rpe_translation_stats, rpe_t, "RPE translation")
    _assert_stats(
        ev.rpe_rotation_stats, _evo_stats(evo_metrics.RPE(deg, 1, evo_metrics.Unit.frames), (r, e)), "RPE rot"
    )


@pytest.mark.parametrize(("delta", "unit"), [(10, "frames"), (0.5, "m"), (1.0, "m")])
@pytest.mark.parametrize("pair", sorted(PAIRS))
def test_rpe_steps_in_frames_and_metres_equal_evo(loaded, pair, delta, unit):
    ref, est, evo_ref, evo_est = loaded[pair]
    r, e, _ = _evo_pipeline(evo_ref, evo_est, "sim3")  # sim3: the path lengths are those of the rescaled estimate
    ev = evaluate(ref, est, align="sim3", rpe_delta=delta, rpe_unit=unit)
    evo_unit = evo_metrics.Unit.frames if unit == "frames" else evo_metrics.Unit.meters
    metric = evo_metrics.RPE(evo_metrics.PoseRelation.translation_part, delta, evo_unit)
    _assert_stats(ev.rpe_translation_stats, _evo_stats(metric, (r, e)), f"RPE {delta} {unit}")
    assert ev.rpe_pairs[:, 1].tolist() == metric.delta_ids


@pytest.mark.parametrize(("delta", "unit"), [(7, "frames"), (0.3, "m")])
def test_all_pairs_equal_evo(loaded, delta, unit):
    _, _, evo_ref, evo_est = loaded["fr2_desk"]
    r, e, _ = _evo_pipeline(evo_ref, evo_est, "se3")
    if unit == "frames":
        want = evo_filters.filter_pairs_by_index(e.poses_se3, delta, all_pairs=True)
    else:
        want = evo_filters.filter_pairs_by_path(e.poses_se3, delta, 0.1 * delta, all_pairs=True)
    got = rpe_pairs(e.positions_xyz, delta, unit, all_pairs=True)
    assert [tuple(p) for p in got.tolist()] == want


@pytest.mark.parametrize(("max_diff", "offset"), [(0.01, 0.0), (0.002, 0.0), (0.02, 0.015), (0.005, -0.3)])
@pytest.mark.parametrize("pair", sorted(PAIRS))
def test_association_equals_evo(loaded, pair, max_diff, offset):
    ref, est, evo_ref, evo_est = loaded[pair]
    i_ref, i_est = associate(ref.stamps, est.stamps, max_diff, offset)
    r, e = evo_sync.associate_trajectories(
        copy.deepcopy(evo_ref), copy.deepcopy(evo_est), max_diff=max_diff, offset_2=offset
    )
    np.testing.assert_array_equal(ref.stamps[i_ref], r.timestamps)
    np.testing.assert_array_equal(est.stamps[i_est], e.timestamps)


@pytest.mark.parametrize(
    ("align", "n"), [("origin", None), ("scale", None), ("se3", 100), ("sim3", 300), ("scale", 50)]
)
@pytest.mark.parametrize("pair", sorted(PAIRS))
def test_origin_scale_only_and_first_n_alignment_equal_evo(loaded, pair, align, n):
    ref, est, evo_ref, evo_est = loaded[pair]
    r, e = evo_sync.associate_trajectories(copy.deepcopy(evo_ref), copy.deepcopy(evo_est), max_diff=0.01)
    if align == "origin":
        e.align_origin(r)
    else:  # evo_ape --align/--correct_scale/--n_to_align, as main_ape.ape calls it
        e.align(r, correct_scale=align in ("sim3", "scale"), correct_only_scale=align == "scale", n=n or -1)
    ev = evaluate(ref, est, align=align, align_first_n=n)
    np.testing.assert_allclose(ev.positions_est, e.positions_xyz, rtol=0, atol=TOL)
    _assert_stats(ev.ate_stats, _evo_stats(evo_metrics.APE(evo_metrics.PoseRelation.translation_part), (r, e)), "ATE")
    deg = evo_metrics.PoseRelation.rotation_angle_deg
    _assert_stats(ev.orientation_stats, _evo_stats(evo_metrics.APE(deg), (r, e)), "orientation")
    if align == "origin":
        assert ev.ate[0] < 1e-12 and ev.orientation_deg[0] < 1e-6


@pytest.mark.parametrize(("align", "offset"), [("se3", 0.0), ("sim3", 0.004)])
@pytest.mark.parametrize("pair", sorted(PAIRS))
def test_interpolated_sync_equals_evo(loaded, pair, align, offset):
    sync_method = pytest.importorskip("evo.core.sync_method")
    ref, est, evo_ref, evo_est = loaded[pair]
    r, e = evo_sync.associate_trajectories(
        copy.deepcopy(evo_ref),
        copy.deepcopy(evo_est),
        max_diff=0.01,
        offset_2=offset,
        sync_method=sync_method.SyncMethod.interpolation,
    )
    e.align(r, correct_scale=align == "sim3")
    ev = evaluate(ref, est, align=align, offset=offset, sync="interpolate")
    np.testing.assert_allclose(ev.positions_ref, r.positions_xyz, rtol=0, atol=TOL)
    np.testing.assert_allclose(ev.positions_est, e.positions_xyz, rtol=0, atol=TOL)
    _assert_stats(ev.ate_stats, _evo_stats(evo_metrics.APE(evo_metrics.PoseRelation.translation_part), (r, e)), "ATE")
    deg = evo_metrics.PoseRelation.rotation_angle_deg
    _assert_stats(ev.orientation_stats, _evo_stats(evo_metrics.APE(deg), (r, e)), "orientation")
    rpe = evo_metrics.RPE(deg, 1, evo_metrics.Unit.frames)
    _assert_stats(ev.rpe_rotation_stats, _evo_stats(rpe, (r, e)), "RPE rot")
