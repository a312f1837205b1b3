"""Temporary siblings a writer killed outright leaves behind (:func:`dualpose.io._output.remove_stale_siblings`):
each temporary name carries its owner (host, boot, process id and start time); the next writer of the same destination
removes those whose owner is dead, never one of a live process, of another host, or without a marker."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import textwrap

import pytest

from dualpose.io._output import (
    OutputDirectory,
    _host_boot,
    _owner,
    atomic_text_file,
    files_in_place,
    remove_stale_siblings,
)  # fmt: skip

pytestmark = pytest.mark.skipif(not os.path.isdir("/proc/self"), reason="owner liveness is read from /proc (Linux)")

# a writer that announces its temporary output and then waits inside the write, to be killed there
_WRITER = textwrap.dedent("""
    import sys, time
    from dualpose.io._output import OutputDirectory, atomic_text_file
    kind, dest = sys.argv[1], sys.argv[2]
    if kind == "file":
        with atomic_text_file(dest, overwrite=True) as f:
            f.write("partial"); f.flush()
            print("writing", flush=True); time.sleep(60)
    else:
        with OutputDirectory(dest, names=("a.txt",), command="test", force=True).writing() as stage:
            (stage / "a.txt").write_text("partial")
            print("writing", flush=True); time.sleep(60)
""")


def _siblings(parent, name: str) -> list[str]:
    return sorted(n for n in os.listdir(parent) if n.startswith(f".{name}.dualpose-"))


def _start_writer(kind: str, dest) -> subprocess.Popen[str]:
    proc = subprocess.Popen([sys.executable, "-c", _WRITER, kind, str(dest)], stdout=subprocess.PIPE, text=True)
    assert proc.stdout is not None and proc.stdout.readline().strip() == "writing"
    return proc


def _kill(proc: subprocess.Popen[str]) -> None:
    proc.send_signal(signal.SIGKILL)
    proc.wait(timeout=30)
    assert proc.returncode == -signal.SIGKILL


@pytest.mark.parametrize("kind", ["file", "directory"])
def test_a_sibling_left_by_sigkill_is_removed_by_the_next_writer_and_a_live_ones_is_not(tmp_path, kind):
    dest = tmp_path / ("out.txt" if kind == "file" else "run")
    killed = _start_writer(kind, dest)
    stale = _siblings(tmp_path, dest.name)
    assert len(stale) == 1 and f"-{killed.pid}-" in stale[0]
    _kill(killed)
    assert _siblings(tmp_path, dest.name) == stale  # what SIGKILL leaves: a sibling, the destination untouched
    assert not dest.exists()
    live = _start_writer(kind, dest)  # a live writer of the same destination: the stale sibling goes, its own stays
    try:
        now = _siblings(tmp_path, dest.name)
        assert stale[0] not in now and len(now) == 1 and f"-{live.pid}-" in now[0]
        if kind == "file":
            with atomic_text_file(dest, overwrite=True) as f:
                f.write("done\n")
            assert dest.read_text() == "done\n"
        else:
            with OutputDirectory(dest, names=("a.txt",), command="test", force=True).writing() as stage:
                (stage / "a.txt").write_text("done\n")
            assert (dest / "a.txt").read_text() == "done\n"
        assert _siblings(tmp_path, dest.name) == now  # the live writer's sibling was left alone
    finally:
        _kill(live)
    assert remove_stale_siblings(dest) == [tmp_path / now[0]]
    assert _siblings(tmp_path, dest.name) == []


def test_only_siblings_of_this_host_whose_owner_is_dead_are_removed(tmp_path):
    host, boot = _host_boot()
    dead = subprocess.Popen([sys.executable, "-c", "pass"])
    dead.wait()
    me = _owner()
    assert me.split("-")[3] not in ("0", "1")  # the start time is known
    names = {
        f".x.csv.dualpose-tmp-{host}-{boot}-{dead.pid}-1-abc.csv": False,  # a dead process of this boot
        f".x.csv.dualpose-tmp-{host}-{'f' * 8 if boot != 'f' * 8 else 'e' * 8}-{os.getpid()}-1-abc.csv": False,
        f".x.csv.dualpose-old-{host}-{boot}-{dead.pid}-1-abc": False,  # an earlier set being replaced, directory
        f".x.csv.dualpose-tmp-{me}abc.csv": True,  # this (live) process
        # this process's id with another start time (not 1 tick after boot): the id was reused, its writer is dead
        f".x.csv.dualpose-tmp-{host}-{boot}-{os.getpid()}-1-abc.csv": False,
        f".x.csv.dualpose-tmp-{'0' * 8 if host != '0' * 8 else '1' * 8}-{boot}-{dead.pid}-1-abc.csv": True,  # host
        ".x.csv.dualpose-tmp-abcdef.csv": True,  # written before owner markers: unknown owner
        ".y.csv.dualpose-tmp-" + f"{host}-{boot}-{dead.pid}-1-abc.csv": True,  # another destination's
    }
    for name in names:
        if "dualpose-old-" in name:
            os.mkdir(tmp_path / name)
            (tmp_path / name / "set").mkdir()
        else:
            (tmp_path / name).write_text("partial")
    removed = {p.name for p in remove_stale_siblings(tmp_path / "x.csv")}
    assert removed == {n for n, keep in names.items() if not keep}
    assert sorted(os.listdir(tmp_path)) == sorted(n for n, keep in names.items() if keep)


def test_files_in_place_removes_a_stale_staging_directory(tmp_path):
    host, boot = _host_boot()
    dead = subprocess.Popen([sys.executable, "-c", "pass"])
    dead.wait()
    stale = tmp_path / f".rec.dualpose-tmp-{host}-{boot}-{dead.pid}-1-abcdefgh"
    stale.mkdir()
    (stale / "imu.csv").write_text("partial")
    with files_in_place(tmp_path / "rec", ["imu.csv"], overwrite=False) as stage:
        (stage / "imu.csv").write_text("t\n")
    assert sorted(os.listdir(tmp_path)) == ["rec"]
