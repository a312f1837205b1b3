"""The output writer (:mod:`dualpose.io._output`): an output appears complete or not at all, an ``--out`` directory is
one run's set with its manifest, ``force`` replaces the whole set, an input is never among the outputs, and the
location is checked before anything is computed."""

from __future__ import annotations

import hashlib
import json
import os
import shutil
import signal
import threading

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from dualpose.io._output import MANIFEST, OutputDirectory, OutputError, OutputFile, atomic_text_file

NAMES = ("a.txt", "b.txt", "old_only.txt")


def _leftovers(parent) -> list[str]:
    """Temporary siblings the writer left behind in ``parent``."""
    return [n for n in os.listdir(parent) if ".dualpose-" in n]


def _write_set(out, files: dict[str, str], force: bool = False, inputs=()) -> None:
    target = OutputDirectory(out, names=NAMES, command="dualpose test", force=force, inputs=inputs)
    with target.writing() as stage:
        for name, text in files.items():
            (stage / name).write_text(text)


def test_a_new_directory_gets_the_files_and_a_manifest_of_them(tmp_path):
    out = tmp_path / "run"
    _write_set(out, {"a.txt": "alpha\n", "b.txt": "beta\n"})
    assert sorted(os.listdir(out)) == ["a.txt", "b.txt", MANIFEST]
    manifest = json.loads((out / MANIFEST).read_text())
    assert manifest["command"] == "dualpose test" and manifest["dualpose_version"]
    for entry in manifest["files"]:
        data = (out / entry["name"]).read_bytes()
        assert entry["bytes"] == len(data) and entry["sha256"] == hashlib.sha256(data).hexdigest()
    assert [e["name"] for e in manifest["files"]] == ["a.txt", "b.txt"]
    assert _leftovers(tmp_path) == []


def test_force_replaces_the_whole_set_and_without_it_nothing_changes(tmp_path):
    out = tmp_path / "run"
    _write_set(out, {"a.txt": "1", "old_only.txt": "stale"})
    with pytest.raises(OutputError, match="earlier run's output.*--force"):
        OutputDirectory(out, names=NAMES, command="x")
    _write_set(out, {"a.txt": "2", "b.txt": "2"}, force=True)
    assert sorted(os.listdir(out)) == ["a.txt", "b.txt", MANIFEST]  # old_only.txt of the earlier run is gone
    assert (out / "a.txt").read_text() == "2" and _leftovers(tmp_path) == []


@pytest.mark.parametrize("exc", [RuntimeError("boom"), KeyboardInterrupt()])
def test_an_error_or_ctrl_c_while_writing_leaves_the_previous_set(tmp_path, exc):
    out = tmp_path / "run"
    _write_set(out, {"a.txt": "first"})
    before = {n: (out / n).read_bytes() for n in os.listdir(out)}
    target = OutputDirectory(out, names=NAMES, command="x", force=True)
    with pytest.raises(type(exc)), target.writing() as stage:
        (stage / "a.txt").write_text("half")
        raise exc
    assert {n: (out / n).read_bytes() for n in os.listdir(out)} == before
    assert _leftovers(tmp_path) == []
    fresh = tmp_path / "never"
    with pytest.raises(type(exc)), OutputDirectory(fresh, names=NAMES, command="x").writing() as stage:
        (stage / "a.txt").write_text("half")
        raise exc
    assert not fresh.exists() and _leftovers(tmp_path) == []


def test_a_directory_with_files_dualpose_did_not_write_is_never_replaced(tmp_path):
    out = tmp_path / "mine"
    out.mkdir()
    (out / "thesis.tex").write_text("years of work")
    with pytest.raises(OutputError, match=r"did not write there \(thesis\.tex\)"):
        OutputDirectory(out, names=NAMES, command="x", force=True)
    _write_set(tmp_path / "run", {"a.txt": "1"})
    (tmp_path / "run" / "notes.txt").write_text("added later by hand")
    with pytest.raises(OutputError, match="notes.txt"):
        OutputDirectory(tmp_path / "run", names=NAMES, command="x", force=True)
    empty = tmp_path / "empty"
    empty.mkdir()
    _write_set(empty, {"a.txt": "1"})  # an empty directory takes a set without --force
    assert (empty / "a.txt").read_text() == "1"


def test_a_set_without_manifest_is_recognised_by_the_names_the_command_writes(tmp_path):
    out = tmp_path / "old"
    out.mkdir()
    (out / "a.txt").write_text("written before manifests existed")
    _write_set(out, {"b.txt": "new"}, force=True)
    assert sorted(os.listdir(out)) == ["b.txt", MANIFEST]


def test_an_input_is_never_among_the_outputs(tmp_path):
    data = tmp_path / "recording"
    data.mkdir()
    (data / "imu.csv").write_text("1,2,3\n")
    link = tmp_path / "link"
    link.symlink_to(data)
    for out, inputs, reason in [
        (data, [data], "is the input directory"),
        (link, [data], "is the input directory"),  # the real path counts, not the spelling
        (data / "results", [data], "lies inside the input directory"),
        (tmp_path, [data / "imu.csv"], "contains the input file"),
        (tmp_path / "recording" / ".." / "recording", [str(data / "imu.csv")], "contains the input file"),
    ]:
        with pytest.raises(OutputError, match=reason):
            OutputDirectory(out, names=NAMES, command="x", force=True, inputs=inputs)
    with pytest.raises(OutputError, match="is the input file"):
        OutputFile(data / "imu.csv", force=True, inputs=[data / "imu.csv"], option="--plot")
    assert (data / "imu.csv").read_text() == "1,2,3\n"


def test_an_unusable_location_is_refused_when_the_writer_is_made(tmp_path):
    (tmp_path / "file").write_text("x")
    for out, reason in [(tmp_path / "file", "not a directory"), (tmp_path / "file" / "sub", "not a directory"),
                        ("/proc/dualpose-out", "not writable|cannot be created")]:  # fmt: skip
        with pytest.raises(OutputError, match=reason):
            OutputDirectory(out, names=NAMES, command="x")
    with pytest.raises(OutputError, match="cannot be created"):
        OutputFile("/proc/dualpose-plot.png", option="--plot")
    with pytest.raises(OutputError, match="is a directory"):
        OutputFile(tmp_path, force=True)


def test_an_output_file_appears_complete_or_not_at_all(tmp_path):
    p = tmp_path / "plot.png"
    with pytest.raises(KeyboardInterrupt), OutputFile(p).writing() as tmp:
        tmp.write_bytes(b"half")
        raise KeyboardInterrupt
    assert not p.exists() and _leftovers(tmp_path) == []
    with OutputFile(p).writing() as tmp:
        assert tmp.suffix == ".png"  # writers that go by the extension see the destination's
        tmp.write_bytes(b"done")
    with pytest.raises(OutputError, match="file exists; use --force"):
        OutputFile(p)
    with pytest.raises(RuntimeError), OutputFile(p, force=True).writing() as tmp:
        tmp.write_bytes(b"")
        raise RuntimeError
    assert p.read_bytes() == b"done" and _leftovers(tmp_path) == []


def test_text_writers_never_leave_a_partial_file(tmp_path):
    p = tmp_path / "traj.tum"
    with pytest.raises(ValueError), atomic_text_file(p, overwrite=False) as f:
        f.write("0 0 0 0 0 0 0 1\n")
        raise ValueError("the writer failed half-way")
    assert not p.exists() and _leftovers(tmp_path) == []
    with atomic_text_file(p, overwrite=False) as f:
        f.write("done\n")
    with pytest.raises(FileExistsError, match="overwrite=True"):
        atomic_text_file(p, overwrite=False).__enter__()
    assert p.read_text() == "done\n"


def test_the_current_directory_is_never_an_output_set(tmp_path, monkeypatch):
    work = tmp_path / "work"
    work.mkdir()
    monkeypatch.chdir(work)
    for out in (".", str(work), str(tmp_path)):
        with pytest.raises(OutputError, match="current directory"):
            OutputDirectory(out, names=NAMES, command="x", force=True)
    _write_set("run/", {"a.txt": "1"})  # a trailing slash names the same directory
    _write_set("run/.", {"a.txt": "2"}, force=True)
    assert (work / "run" / "a.txt").read_text() == "2" and _leftovers(work) == []


_RUN = st.tuples(st.sets(st.sampled_from(NAMES), min_size=1), st.booleans(), st.booleans())


@settings(max_examples=40, deadline=None)
@given(st.lists(_RUN, min_size=1, max_size=5))
def test_any_sequence_of_runs_leaves_one_runs_set(tmp_path_factory, runs):
    """Runs writing some of the names, with or without ``force``, some failing half-way: after each, the directory
    is exactly the last successful run's files and manifest (or absent), and no temporary sibling is left."""
    parent = tmp_path_factory.mktemp("seq")
    out = parent / "run"
    expected: dict[str, str] | None = None
    for k, (names, force, fails) in enumerate(runs):
        files = {name: f"run {k}" for name in sorted(names)}
        try:
            target = OutputDirectory(out, names=NAMES, command=f"run {k}", force=force)
        except OutputError:
            assert expected is not None and not force  # refused only over an earlier set without --force
        else:
            try:
                with target.writing() as stage:
                    for name, text in files.items():
                        (stage / name).write_text(text)
                    if fails:
                        raise RuntimeError("failed half-way")
                expected = files
            except RuntimeError:
                pass
        if expected is None:
            assert not out.exists()
        else:
            assert {n: (out / n).read_text() for n in os.listdir(out) if n != MANIFEST} == expected
            _manifest = json.loads((out / MANIFEST).read_text())
            assert sorted(e["name"] for e in _manifest["files"]) == sorted(expected)
        assert _leftovers(parent) == []


@pytest.mark.skipif(not hasattr(signal, "pthread_kill"), reason="POSIX signals")
def test_a_ctrl_c_during_the_clean_up_lands_after_it(tmp_path, monkeypatch):
    """A real SIGINT sent as the earlier set and the temporary directory are being removed (the new set already in
    place) is held back until both are gone: the new set is whole and nothing is left beside it."""
    out = tmp_path / "run"
    _write_set(out, {"a.txt": "first"})
    real_rmtree, sent = shutil.rmtree, []

    def rmtree_with_ctrl_c(path, *args, **kwargs):
        if not sent:
            sent.append(path)
            signal.pthread_kill(threading.main_thread().ident, signal.SIGINT)
        real_rmtree(path, *args, **kwargs)

    monkeypatch.setattr(shutil, "rmtree", rmtree_with_ctrl_c)
    with pytest.raises(KeyboardInterrupt):
        _write_set(out, {"a.txt": "second", "b.txt": "2"}, force=True)
    monkeypatch.setattr(shutil, "rmtree", real_rmtree)
    assert sent and (out / "a.txt").read_text() == "second" and (out / "b.txt").read_text() == "2"
    assert _leftovers(tmp_path) == []
