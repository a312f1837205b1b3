"""The numba cache guard: stale kernels (a helper module changed) are deleted; fresh ones are kept."""

from __future__ import annotations

from pathlib import Path

from dualpose import _kernel_cache as kc


def _tree(tmp_path: Path) -> tuple[Path, Path]:
    pkg = tmp_path / "pkg"
    cache = pkg / "__pycache__"
    cache.mkdir(parents=True)
    (pkg / "_kern.py").write_text("import numba\n")
    (pkg / "_helper.py").write_text("import numba\nX = 1\n")
    (pkg / "plain.py").write_text("Y = 2\n")
    return pkg, cache


def _compile(cache: Path) -> list[Path]:
    files = [cache / "_kern.f-3.py311.nbi", cache / "_kern.f-3.py311.1.nbc", cache / "other.g-1.py311.nbi"]
    files.append(cache / "guf-_kern.f-3.py311.nbi")  # the wrapper numba caches for a guvectorize kernel
    for f in files:
        f.write_bytes(b"x")
    return files


def test_fresh_cache_is_kept_and_helper_edit_invalidates(tmp_path, monkeypatch):
    monkeypatch.delenv("NUMBA_CACHE_DIR", raising=False)
    monkeypatch.setattr(kc, "_digest", None)
    pkg, cache = _tree(tmp_path)
    kern_i, kern_c, other, guf = _compile(cache)
    kc.mark_fresh(pkg)
    kc.ensure_fresh(pkg)
    assert kern_i.exists() and kern_c.exists() and guf.exists()

    # Editing only the helper (not the kernel file) must invalidate the kernel's cache.
    (pkg / "_helper.py").write_text("import numba\nX = 2\n")
    monkeypatch.setattr(kc, "_digest", None)
    kc.ensure_fresh(pkg)
    assert not kern_i.exists() and not kern_c.exists()
    assert not guf.exists()  # a stale gufunc wrapper around the rebuilt kernel segfaults
    assert other.exists()  # not a dualpose module: untouched


def test_unstamped_cache_is_rebuilt_and_plain_files_do_not_count(tmp_path, monkeypatch):
    monkeypatch.delenv("NUMBA_CACHE_DIR", raising=False)
    monkeypatch.setattr(kc, "_digest", None)
    pkg, cache = _tree(tmp_path)
    before = kc.source_digest(pkg)
    (pkg / "plain.py").write_text("Y = 3\n")
    assert kc.source_digest(pkg) == before
    kern_i, _, _, _ = _compile(cache)
    kc.ensure_fresh(pkg)
    assert not kern_i.exists()


def test_user_cache_dir_is_covered(tmp_path, monkeypatch):
    pkg, _ = _tree(tmp_path)
    user = tmp_path / "user" / "pkg_abc123"
    user.mkdir(parents=True)
    monkeypatch.setenv("NUMBA_CACHE_DIR", str(tmp_path / "user"))
    monkeypatch.setattr(kc, "_digest", None)
    kern_i, _, _, _ = _compile(user)
    kc.mark_fresh(pkg)
    (pkg / "_kern.py").write_text("import numba\n# edited\n")
    monkeypatch.setattr(kc, "_digest", None)
    kc.ensure_fresh(pkg)
    assert not kern_i.exists()
