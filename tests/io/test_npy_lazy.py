"""``dualpose.io.read_npy_lazy``: a ``.npy`` file as a lazy dask array, read block by block from its memory map.

References: ``np.load`` of the same file (values, shape, dtype) and the NumPy product on the loaded arrays (bit for
bit); "no copy" is checked on the blocks themselves (views of the map, owning no data) and with ``tracemalloc``
(NumPy's buffers) while the array is made.
"""

from __future__ import annotations

import pickle
import tracemalloc
from pathlib import Path

import numpy as np
import pytest

import dualpose as dp
from dualpose.io import read_npy_lazy

da = pytest.importorskip("dask.array")
dask = pytest.importorskip("dask")
get_sync = pytest.importorskip("dask.local").get_sync


@pytest.fixture
def quats(tmp_path: Path) -> tuple[Path, Path, np.ndarray, np.ndarray]:
    rng = np.random.default_rng(7)
    p, q = rng.standard_normal((1000, 4)), rng.standard_normal((1000, 4))
    np.save(tmp_path / "p.npy", p)
    np.save(tmp_path / "q.npy", q)
    return tmp_path / "p.npy", tmp_path / "q.npy", p, q


def test_values_chunks_and_dtype_are_the_files(quats: tuple[Path, Path, np.ndarray, np.ndarray]) -> None:
    pp, _, p, _ = quats
    x = read_npy_lazy(pp, 300)
    assert isinstance(x, da.Array)
    assert x.shape == p.shape and x.dtype == p.dtype
    assert x.chunks == ((300, 300, 300, 100), (4,))
    assert np.array_equal(x.compute(), p)
    assert read_npy_lazy(str(pp), 300).name == x.name  # the same file and chunks give the same keys


def test_lazy_product_from_files_is_numpys_bit_for_bit(quats: tuple[Path, Path, np.ndarray, np.ndarray]) -> None:
    pp, qp, p, q = quats
    lazy = dp.quat_mul(read_npy_lazy(pp, 128), read_npy_lazy(qp, 128))
    assert isinstance(lazy, da.Array)
    expected = dp.quat_mul(p, q)
    assert np.array_equal(lazy.compute(scheduler="threads"), expected)
    assert lazy.sum().compute(scheduler="sync") == sum(expected[i:i + 128].sum() for i in range(0, 1000, 128))


def test_blocks_are_views_of_the_map_not_copies(tmp_path: Path) -> None:
    a = np.arange(4 * 2**18, dtype=np.float64).reshape(-1, 4)  # 8 MiB
    np.save(tmp_path / "a.npy", a)
    del a
    tracemalloc.start()
    try:
        x = read_npy_lazy(tmp_path / "a.npy", 2**14)
        made = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert made < 2**20  # far below the file's 8 MiB: nothing was read or copied
    # the block a task hands on (the graph's own key, not a computed result that dask may finalise by copying)
    block = get_sync(dict(x.__dask_graph__()), (x.name, 3, 0))
    assert type(block) is np.ndarray and not block.flags.owndata and not block.flags.writeable
    assert block[0, 0] == 3 * 2**14 * 4


def test_pickles_as_the_path_only(tmp_path: Path) -> None:
    np.save(tmp_path / "a.npy", np.ones((2**18, 4)))  # 8 MiB
    x = read_npy_lazy(tmp_path / "a.npy", 2**16)
    assert len(pickle.dumps(x)) < 2**16  # a process scheduler is sent the graph, never the data
    assert dask.compute(x.sum(), scheduler="processes", num_workers=1)[0] == 4 * 2**18


def test_other_shapes_and_dtypes(tmp_path: Path) -> None:
    for a in (np.arange(10, dtype=np.int32), np.zeros((0, 4)), np.arange(24.0).reshape(2, 3, 4)):
        np.save(tmp_path / "x.npy", a)
        x = read_npy_lazy(tmp_path / "x.npy", 2)
        assert x.dtype == a.dtype and np.array_equal(x.compute(), a)


@pytest.mark.parametrize("chunk_rows", [0, -3, 2.5, True, "10"])
def test_rejects_a_chunk_size_that_is_not_a_positive_integer(quats: tuple[Path, Path, np.ndarray, np.ndarray],
                                                             chunk_rows: object) -> None:
    with pytest.raises(ValueError, match="chunk_rows must be a positive integer"):
        read_npy_lazy(quats[0], chunk_rows)  # type: ignore[arg-type]


def test_rejects_scalars_object_arrays_and_other_files(tmp_path: Path) -> None:
    np.save(tmp_path / "s.npy", np.float64(1.0))
    with pytest.raises(ValueError, match="s.npy: the stored array has no axes"):
        read_npy_lazy(tmp_path / "s.npy", 4)
    np.save(tmp_path / "o.npy", np.array([{"a": 1}, None], dtype=object), allow_pickle=True)
    with pytest.raises(ValueError, match="o.npy: cannot map the array"):
        read_npy_lazy(tmp_path / "o.npy", 4)
    (tmp_path / "t.npy").write_text("not a numpy file\n")
    with pytest.raises(ValueError, match="t.npy: cannot map the array"):
        read_npy_lazy(tmp_path / "t.npy", 4)
