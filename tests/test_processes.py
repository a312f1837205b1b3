"""dualpose in many processes at once, in fresh interpreters, as an account that cannot write the install, and in a
dask process pool: no crash and the same results everywhere (the kernels are compiled at install, nothing is
written at run time)."""

from __future__ import annotations

import json
import os
import shutil
import site
import subprocess
import sys
import textwrap

import numpy as np
import pytest

import dualpose
from dualpose import _native

#: a fresh process's first use of the library: import, then the first call of kernels of every layer
SCRIPT = textwrap.dedent(
    """
    import json, sys
    import numpy as np
    import dualpose as dp
    from dualpose import registration
    from dualpose.inertial import integrate_attitude
    rng = np.random.default_rng(int(sys.argv[1]))
    q = dp.quat_from_rotvec(rng.normal(size=(64, 3)))
    p = dp.quat_mul(q, q[::-1])
    a = dp.dualquat_from_qt(q[0], [1.0, 2.0, 3.0])
    b = dp.dualquat_from_qt(q[1], [-1.0, 0.5, 0.0])
    s = dp.dualquat_sclerp(a, b, np.linspace(0.0, 1.0, 5))
    pts = rng.normal(size=(10, 3))
    est = registration.register_pose(pts, dp.quat_rotate(q[2], pts) + [0.1, 0.2, 0.3])
    att = integrate_attitude(q[3], 1e-3 * rng.normal(size=(12, 3)), samples=3)
    print(json.dumps({"p": p.tolist(), "s": s.tolist(), "quat": est.quat.tolist(), "att": att.tolist()}))
    """
)


def _run(seed: int, python: str = sys.executable, prelude: str = "", **kwargs) -> subprocess.Popen:
    return subprocess.Popen([python, "-c", prelude + SCRIPT, str(seed)], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, **kwargs)  # fmt: skip


def _interpreter_for_nobody() -> tuple[str, str]:
    """An interpreter ``nobody`` may execute, and the prelude that gives it this environment's packages: this
    one when its path is world-executable, else the system's python of the same version with this environment's
    site-packages added (``site.addsitedir`` also runs the editable install's ``.pth`` hook)."""
    exe = os.path.realpath(sys.executable)
    if _world_executable(exe):
        return sys.executable, ""
    system = shutil.which(f"python{sys.version_info.major}.{sys.version_info.minor}", path="/usr/local/bin:/usr/bin")
    if system is None or not _world_executable(os.path.realpath(system)):
        pytest.skip("no interpreter that the nobody account may execute")
    sites = [p for p in site.getsitepackages() if p.startswith(sys.prefix)]
    return system, "import site\n" + "".join(f"site.addsitedir({p!r})\n" for p in sites)


def _searchable(path: str) -> bool:
    """Every directory above ``path`` searchable by others."""
    parts = os.path.abspath(path).split(os.sep)
    return all(os.stat(os.sep.join(parts[:i]) or os.sep).st_mode & 0o001 for i in range(2, len(parts)))


def _world_executable(path: str) -> bool:
    """Every directory on ``path`` searchable and the file executable by others."""
    return _searchable(path) and bool(os.stat(path).st_mode & 0o001)


def _install_readable_by_others() -> bool:
    """Whether another account can reach this environment's packages and dualpose (an editable install reads the
    checkout): false when the checkout or the venv lies below a private directory (e.g. ``mktemp -d``)."""
    return all(_searchable(m.__file__) and os.stat(m.__file__).st_mode & 0o004 for m in (np, dualpose, _native))


def _results(procs: list[subprocess.Popen]) -> list[dict]:
    out = []
    for proc in procs:
        stdout, stderr = proc.communicate(timeout=120)
        assert proc.returncode == 0, f"exit {proc.returncode}: {stderr[-2000:]}"
        out.append(json.loads(stdout))
    return out


def test_fresh_interpreters_started_at_once_agree() -> None:
    """Six interpreters started together (as pytest -n, multiprocessing or a job array do): all succeed and the
    same seed gives the same numbers to the last bit in every one of them."""
    procs = [_run(seed) for seed in (0, 1, 2, 0, 1, 2)]
    res = _results(procs)
    for i in range(3):
        assert res[i] == res[i + 3]
    assert res[0] != res[1]


@pytest.mark.skipif(not hasattr(os, "geteuid") or os.geteuid() != 0, reason="needs root to switch to nobody")
def test_an_account_that_cannot_write_the_install() -> None:
    """Run as ``nobody`` (uid 65534), who cannot write the installation or the checkout: the same results."""
    if not _install_readable_by_others():
        pytest.skip("this checkout or environment lies below a directory other accounts cannot enter")
    python, prelude = _interpreter_for_nobody()
    nobody = {"preexec_fn": lambda: (os.setgid(65534), os.setuid(65534)),
              "env": {**os.environ, "HOME": "/nonexistent"}, "cwd": "/"}  # fmt: skip
    ours, theirs = _results([_run(5), _run(5, python, prelude, **nobody)])
    assert ours == theirs


def _quat_block(block: np.ndarray) -> np.ndarray:
    import dualpose as dp

    q = dp.quat_from_rotvec(block)
    return dp.quat_mul(q, dp.quat_conj(q[::-1]))


def test_dask_process_pool_over_the_batched_algebra() -> None:
    """``map_blocks`` over quat_from_rotvec / quat_mul with dask's process scheduler (two worker processes)."""
    dask = pytest.importorskip("dask")
    import dask.array as da

    rng = np.random.default_rng(7)
    v = rng.normal(size=(4000, 3))
    arr = da.from_array(v, chunks=(1000, 3))
    out = arr.map_blocks(_quat_block, chunks=(1000, 4), dtype=float)
    with dask.config.set(scheduler="processes", num_workers=2):
        got = out.compute()
    want = np.concatenate([_quat_block(v[i : i + 1000]) for i in range(0, 4000, 1000)])
    np.testing.assert_array_equal(got, want)
