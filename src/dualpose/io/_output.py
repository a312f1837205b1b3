"""Output written as a unit: every file a command writes goes into a temporary sibling of its destination (same
directory, so the same file system) and is renamed into place only when complete.

* :class:`OutputFile`: one file (``eval --plot FILE``, the writers of :mod:`dualpose.io`).  An interrupted or failed
  run leaves the previous file, or none, never a partial or empty one.
* :class:`OutputDirectory`: an output directory as a unit (``fuse --out DIR``, ``reproduce ... --out DIR``).  The run's
  files are written into ``.DIR.dualpose-tmp-XXXX`` beside ``DIR`` with a ``manifest.json`` (each file's name, size
  and SHA-256, the command, the dualpose version, the time), then that directory takes the place of ``DIR``.  With
  ``force`` an earlier output set is replaced as a whole (no file of an earlier run survives next to the new
  ones); a directory holding anything the command did not write is never replaced.

Both check the destination when they are made, before any computation: the place must be writable (a trial file is
created and removed: permission bits do not tell the whole story; ``/proc`` and read-only mounts refuse root too),
must not exist unless ``force`` is given, and must not be, lie inside, or contain an input (real paths compared, so a
symbolic link or ``..`` does not hide an input).  Problems raise :class:`OutputError` with a one-line message naming
the path and the reason.  Ctrl-C (``SIGINT``) is held back while the finished output is renamed into place and
while the temporary siblings are removed.
"""

from __future__ import annotations

import contextlib
import datetime
import functools
import hashlib
import json
import os
import re
import shutil
import signal
import stat
import tempfile
import threading
from collections.abc import Iterable, Iterator
from pathlib import Path
from typing import IO, Any

from dualpose.types import _inputs

__all__ = [
    "OutputError", "OutputFile", "OutputDirectory", "MANIFEST", "atomic_path", "atomic_text_file", "files_in_place",
    "remove_stale_siblings", "temporary_sibling_dir",
]

#: name of the manifest in every output directory
MANIFEST = "manifest.json"
_TMP = ".dualpose-tmp-"
_OLD = ".dualpose-old-"
#: the owner marker of a temporary name: ``HOST-BOOT-PID-START-`` (:func:`_owner`), then tempfile's random letters
_MARKED = re.compile(r"([0-9a-f]{8})-([0-9a-f]{8})-([0-9]+)-([0-9]+)-")


class OutputError(ValueError):
    """An output location that cannot take the output: the message names the path and the reason."""


def _real(path: str | os.PathLike[str]) -> Path:
    return Path(os.path.realpath(os.fspath(path)))


def _inside(child: Path, parent: Path) -> bool:
    return child == parent or parent in child.parents


def _input_problem(out: Path, inputs: Iterable[str | os.PathLike[str] | None], option: str) -> str | None:
    """The message when the real path of ``out`` is, lies inside, or contains one of the existing ``inputs``."""
    real_out = _real(out)
    for given in inputs:
        if given is None or not os.path.exists(given):
            continue
        real_in = _real(given)
        kind = "directory" if real_in.is_dir() else "file"
        if real_out == real_in:
            return f"{option} {out} is the input {kind} {given}; an input is never overwritten"
        if _inside(real_out, real_in):
            return f"{option} {out} lies inside the input directory {given}; write the output elsewhere"
        if _inside(real_in, real_out):
            return f"{option} {out} contains the input {kind} {given}; replacing it would destroy the input"
    return None


def _digest8(text: str) -> str:
    return hashlib.blake2b(text.encode("utf-8", "surrogateescape"), digest_size=4).hexdigest()


@functools.lru_cache(maxsize=1)
def _host_boot() -> tuple[str, str]:
    """8 hex digits naming this host (its node name) and 8 naming this boot of it (Linux:
    ``/proc/sys/kernel/random/boot_id``; elsewhere the boot time is unknown: ``"0" * 8``)."""
    try:
        with open("/proc/sys/kernel/random/boot_id", encoding="ascii") as f:
            boot = _digest8(f.read().strip())
    except OSError:
        boot = "0" * 8
    return _digest8(os.uname().nodename), boot


def _start_time(pid: int) -> int | None:
    """The start time of process ``pid`` (clock ticks after boot, ``/proc/PID/stat`` field 22); None when no such
    process exists or the system does not say (not Linux)."""
    try:
        with open(f"/proc/{pid}/stat", "rb") as f:
            stat_line = f.read()
    except OSError:
        return None
    try:  # the command name (field 2) may hold blanks and parentheses: the fields after its last ")"
        return int(stat_line[stat_line.rindex(b")") + 2 :].split()[19])
    except (ValueError, IndexError):
        return None


def _owner() -> str:
    """The owner marker this process puts into its temporary names: ``HOST-BOOT-PID-START-`` (:func:`_host_boot`,
    the process id and its start time; 0 where the system does not tell it)."""
    host, boot = _host_boot()
    pid = os.getpid()
    return f"{host}-{boot}-{pid}-{_start_time(pid) or 0}-"


def _owner_alive(host: str, boot: str, pid: int, start: int) -> bool:
    """Whether the process that wrote the owner marker may still be running: True for another host (it cannot be
    asked) and whenever in doubt; False only when it is this host's and the host has rebooted since, no process
    ``pid`` exists, or the process ``pid`` started at another time (the id was reused)."""
    my_host, my_boot = _host_boot()
    if host != my_host:
        return True
    if boot != my_boot and "0" * 8 not in (boot, my_boot):
        return False
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except OSError:  # another user's process (PermissionError): alive
        return True
    now = _start_time(pid)
    return not (start and now is not None and now != start)


def remove_stale_siblings(path: str | os.PathLike[str]) -> list[Path]:
    """Remove the temporary siblings of ``path`` (``.NAME.dualpose-tmp-*``, ``.NAME.dualpose-old-*``) that a writer
    killed outright (``SIGKILL``, power loss) left behind: those whose owner marker names a process of this host that
    is no longer running.  A sibling of a live process, of another host, or without a marker (written before markers
    existed) stays.  Every writer of :mod:`dualpose.io._output` calls it before it writes ``path``.

    Returns
    -------
    list of Path
        The siblings removed.
    """
    target = Path(os.path.abspath(path))
    removed: list[Path] = []
    try:
        entries = os.listdir(target.parent)
    except OSError:
        return removed
    for prefix in (f".{target.name}{_TMP}", f".{target.name}{_OLD}"):
        for entry in entries:
            if not entry.startswith(prefix):
                continue
            m = _MARKED.match(entry, len(prefix))
            if m is None or _owner_alive(m[1], m[2], int(m[3]), int(m[4])):
                continue
            stale = target.parent / entry
            try:
                if stale.is_dir() and not stale.is_symlink():
                    shutil.rmtree(stale)
                else:
                    stale.unlink()
            except FileNotFoundError:  # removed meanwhile by another writer
                continue
            except OSError:
                continue  # not ours to remove (permissions): left as it is
            removed.append(stale)
    return removed


def temporary_sibling_dir(path: str | os.PathLike[str]) -> Path:
    """A new empty directory beside ``path`` (``.NAME.dualpose-tmp-OWNER-XXXXXXXX``, the same file system) to write
    into before renaming into place, after the stale siblings of ``path`` are removed
    (:func:`remove_stale_siblings`).  The caller removes it."""
    target = Path(os.path.abspath(path))
    remove_stale_siblings(target)
    return Path(tempfile.mkdtemp(prefix=f".{target.name}{_TMP}{_owner()}", dir=target.parent))


def _trial_write(directory: Path) -> str | None:
    """None when a file can be created in ``directory``, else the reason."""
    if not os.access(directory, os.W_OK | os.X_OK):
        return "not writable"
    try:
        fd, name = tempfile.mkstemp(prefix=f"{_TMP}write-test-", dir=directory)
    except OSError as exc:
        return f"not writable ({exc.strerror or exc})"
    os.close(fd)
    with contextlib.suppress(OSError):
        os.unlink(name)
    return None


def _parent_problem(out: Path, option: str) -> str | None:
    """None when the parent directory of ``out`` exists (or can be created) and is writable: the output is written
    beside ``out`` and renamed into place, so the parent must take a new entry even when ``out`` exists."""
    parent = out.absolute().parent
    while not parent.exists() and parent != parent.parent:
        parent = parent.parent
    if not parent.is_dir():
        return f"{option} {out}: cannot be created: {parent} is not a directory"
    problem = _trial_write(parent)
    if problem is None:
        return None
    if out.exists():
        return (f"{option} {out}: its directory {parent} is {problem} (the output is written beside it and renamed "
                "into place)")  # fmt: skip
    return f"{option} {out}: cannot be created: {parent} is {problem}"


@contextlib.contextmanager
def _signals_held() -> Iterator[None]:
    """Hold ``SIGINT`` back (main thread only) while the output is renamed into place; it is delivered after."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    old = signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT, signal.SIGTERM})
    try:
        yield
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, old)


class OutputFile:
    """One output file, written into a temporary sibling and renamed into place when complete.

    Parameters
    ----------
    path : path-like
        The destination file.
    force : bool
        Replace an existing file; otherwise an existing file is an :class:`OutputError`.
    inputs : iterable of path-like or None
        The command's input files and directories; ``path`` must not be one of them or lie inside one.
    option : str
        How the message names the destination (``"--plot"``; ``""`` for a plain path).

    Raises
    ------
    OutputError
        At construction, before anything is computed: the destination exists (without ``force``), is a directory or
        an input, or its directory is not writable.
    """

    def __init__(
        self,
        path: str | os.PathLike[str],
        *,
        force: bool = False,
        inputs: Iterable[str | os.PathLike[str] | None] = (),
        option: str = "",
    ) -> None:
        self.path = Path(path)
        self.force = force
        label = f"{option} " if option else ""
        problem = _input_problem(self.path, inputs, option or "output")
        if problem is None and (self.path.exists() or self.path.is_symlink()):
            if self.path.is_dir():
                problem = f"{label}{self.path}: is a directory, not a file"
            elif not force:
                problem = f"{label}{self.path}: file exists; use --force to replace it"
        if problem is None:
            problem = _parent_problem(self.path, option or "output")
        if problem is not None:
            raise OutputError(problem)

    def writing(self) -> contextlib.AbstractContextManager[Path]:
        """The temporary path to write; renamed to :attr:`path` when the block ends normally, removed otherwise."""
        return _file_in_place(self.path, self.force)


@contextlib.contextmanager
def _file_in_place(path: Path, force: bool) -> Iterator[Path]:
    """A temporary sibling of ``path`` to write, renamed to ``path`` when the block ends normally (an existing file
    is replaced only with ``force``: ``FileExistsError`` otherwise), removed on an error or Ctrl-C."""
    directory = path.absolute().parent  # the temporary file keeps the suffix: writers that go by it see the same
    directory.mkdir(parents=True, exist_ok=True)
    remove_stale_siblings(path)
    fd, name = tempfile.mkstemp(prefix=f".{path.name}{_TMP}{_owner()}", suffix=path.suffix, dir=directory)
    os.close(fd)
    tmp = Path(name)
    try:
        yield tmp
        os.chmod(tmp, 0o666 & ~_umask())
        with _signals_held():
            if force:
                os.replace(tmp, path)
            else:
                try:
                    os.link(tmp, path)  # FileExistsError if the file appeared meanwhile: never replaced unasked
                except FileExistsError:
                    raise
                except OSError:  # a file system without hard links (FAT, some network mounts)
                    if path.exists():
                        raise FileExistsError(f"{path}: file exists") from None
                    os.replace(tmp, path)
    finally:
        with _signals_held(), contextlib.suppress(FileNotFoundError):  # a Ctrl-C held back above lands after this
            os.unlink(tmp)


@contextlib.contextmanager
def atomic_path(path: str | os.PathLike[str], overwrite: bool = False) -> Iterator[Path]:
    """A temporary sibling of ``path`` (same suffix) for a writer that takes a file name (matplotlib, pyarrow); the
    file appears at ``path`` complete when the block ends normally, or not at all.  An existing file is a
    ``FileExistsError`` unless ``overwrite``; so is ``path`` being a directory."""
    p = Path(path)
    if p.is_dir():
        raise IsADirectoryError(f"{p}: is a directory, not a file")
    if p.exists() and not overwrite:
        raise FileExistsError(f"{p}: file exists; pass overwrite=True (CLI: --force) to replace it")
    with _file_in_place(p, overwrite) as tmp:
        yield tmp


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


@contextlib.contextmanager
def atomic_text_file(path: str | os.PathLike[str], overwrite: bool) -> Iterator[IO[str]]:
    """A text file (UTF-8, ``\\n`` line ends) that appears at ``path`` complete or not at all.

    An existing file is a ``FileExistsError`` unless ``overwrite``; so is ``path`` being a directory.
    """
    p = Path(path)
    if p.is_dir():
        raise IsADirectoryError(f"{p}: is a directory, not a file")
    if p.exists() and not overwrite:
        raise FileExistsError(f"{p}: file exists; pass overwrite=True (CLI: --force) to replace it")
    try:
        with _file_in_place(p, overwrite) as tmp, open(tmp, "w", encoding="utf-8", newline="\n") as f:
            yield f
    except FileExistsError:
        raise FileExistsError(f"{p}: file exists; pass overwrite=True (CLI: --force) to replace it") from None


@contextlib.contextmanager
def files_in_place(directory: str | os.PathLike[str], names: Iterable[str], overwrite: bool) -> Iterator[Path]:
    """A temporary sibling directory of ``directory`` to write the files ``names`` into; when the block ends
    normally they appear in ``directory`` together, on an error or Ctrl-C none of them does.

    A library writer's directory (:func:`dualpose.io.write_recording`): unlike :class:`OutputDirectory` it writes no
    manifest and leaves other files in ``directory`` alone.  A missing or empty ``directory`` is replaced by the
    temporary one in one rename; into a directory holding other files, the files are renamed one after the other
    once all are written, with Ctrl-C held back.  An existing file of ``names`` is a ``FileExistsError`` unless
    ``overwrite`` (checked before anything is written, and again before the renames).
    """
    target = Path(os.path.abspath(directory))
    wanted = sorted(set(names))

    def check() -> None:
        if target.exists() and not target.is_dir():
            raise NotADirectoryError(f"{target}: not a directory")
        if not overwrite:
            for name in wanted:
                if (target / name).exists():
                    raise FileExistsError(
                        f"{target / name}: file exists; pass overwrite=True (CLI: --force) to replace it")

    check()
    target.parent.mkdir(parents=True, exist_ok=True)
    stage = temporary_sibling_dir(target)
    try:
        yield stage
        written = sorted(os.listdir(stage))
        if set(written) - set(wanted):
            raise RuntimeError(f"files_in_place: unexpected files {_some(written)}")  # pragma: no cover - a bug
        os.chmod(stage, 0o777 & ~_umask())
        with _signals_held():
            check()
            try:
                os.rename(stage, target)  # a missing or empty directory: the set appears in one step
            except OSError:
                if not target.is_dir():
                    raise
                for name in written:  # a directory holding other files
                    os.replace(stage / name, target / name)
    finally:
        with _signals_held():  # a Ctrl-C held back above lands after the clean-up, not inside it
            shutil.rmtree(stage, ignore_errors=True)


def _some(names: list[str]) -> str:
    """The first few of ``names`` for a message."""
    return ", ".join(names[:4]) + (f" and {len(names) - 4} more" if len(names) > 4 else "")


def _sha256(path: Path) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


def _version() -> str:
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version("dualpose")
    except PackageNotFoundError:  # pragma: no cover - running from a source tree without installing
        return "unknown"


class OutputDirectory:
    """An output directory written as a unit, with a ``manifest.json`` of what the run wrote.

    Parameters
    ----------
    path : path-like
        The destination directory.
    names : iterable of str
        Every file name the command can write there (the files of an older set written before manifests existed
        are recognised by these names).
    command : str
        The command line, recorded in the manifest.
    force : bool
        Replace an existing output set as a whole; otherwise an existing non-empty directory is an
        :class:`OutputError`.  A directory holding anything the command did not write (by its manifest, or by
        ``names`` when it has none) is never replaced.
    inputs : iterable of path-like or None
        The command's input files and directories: ``path`` must not be one, lie inside one or contain one.
    option : str
        How the message names the destination (``"--out"``).

    Raises
    ------
    OutputError
        At construction, before anything is computed, with the reason.
    """

    def __init__(
        self,
        path: str | os.PathLike[str],
        *,
        names: Iterable[str],
        command: str,
        force: bool = False,
        inputs: Iterable[str | os.PathLike[str] | None] = (),
        option: str = "--out",
    ) -> None:
        self.path = Path(path)
        self.names = frozenset(names)
        self.command = command
        self.force = force
        problem = _input_problem(self.path, inputs, option)
        if problem is None and _inside(_real(os.getcwd()), _real(self.path)):
            problem = f"{option} {self.path}: is or contains the current directory; give another directory"
        problem = problem or self._existing_problem(option)
        if problem is None:
            problem = _parent_problem(self.path, option)
        if problem is None and self.path.is_dir():
            reason = _trial_write(self.path)
            problem = None if reason is None else f"{option} {self.path}: {reason}"
        if problem is not None:
            raise OutputError(problem)

    def _existing_problem(self, option: str) -> str | None:
        p = self.path
        if not (p.exists() or p.is_symlink()):
            return None
        if p.is_symlink() or not p.is_dir():
            what = "a symbolic link" if p.is_symlink() else "not a directory"
            return f"{option} {p}: {what}; give a new or empty directory"
        entries = sorted(os.listdir(p))
        if not entries:
            return None
        foreign = [e for e in entries if e not in self._earlier_set()]
        if foreign:
            return (f"{option} {p}: holds files dualpose did not write there ({_some(foreign)}); give a new or "
                    "empty directory")  # fmt: skip
        if not self.force:
            return f"{option} {p}: holds an earlier run's output ({_some(entries)}); use --force to replace it"
        changed = self._changed_files()
        if changed:
            return (f"{option} {p}: {changed}: the file was changed after dualpose wrote it, so --force does not "
                    "replace it; move it away or give a new directory")  # fmt: skip
        return None

    def _manifest_files(self) -> list[dict[str, Any]] | None:
        """The ``files`` entries of the earlier set's manifest; None without a readable one."""
        try:
            with open(self.path / MANIFEST, encoding="utf-8") as f:
                files = json.load(f)["files"]
            return [dict(entry) for entry in files]
        except (OSError, ValueError, KeyError, TypeError):
            return None

    def _earlier_set(self) -> frozenset[str]:
        """The names an earlier output set in :attr:`path` may hold: its manifest's files, else :attr:`names`."""
        files = self._manifest_files()
        if files is None:
            return self.names
        try:
            return frozenset([MANIFEST, *(str(entry["name"]) for entry in files)])
        except KeyError:
            return self.names

    def _changed_files(self) -> str | None:
        """The first file of the earlier set whose size or SHA-256 disagrees with its manifest entry (the manifest
        repeats what each file holds): a file a user changed after the run is no longer dualpose's to replace."""
        for entry in self._manifest_files() or ():
            f = self.path / str(entry.get("name", ""))
            if not f.is_file():
                continue
            got: object
            if "bytes" in entry and entry["bytes"] != f.stat().st_size:
                key, got = "bytes", f.stat().st_size
            elif "sha256" in entry and entry["sha256"] != _sha256(f):
                key, got = "sha256", _sha256(f)
            else:
                continue
            return str(_inputs.disagreement(str(entry["name"]), MANIFEST, "what the run wrote", f"the file's {key} "
                                            f"is {got}, the manifest lists {entry[key]}"))  # fmt: skip
        return None

    @contextlib.contextmanager
    def writing(self) -> Iterator[Path]:
        """The temporary directory to write the files into; on a normal end it gets ``manifest.json`` and takes
        the place of :attr:`path` (an earlier set is removed); on an error or Ctrl-C it is removed and :attr:`path`
        is left as it was."""
        target = Path(os.path.abspath(self.path))  # "run/." and "run/" name the directory "run"
        parent = target.parent
        parent.mkdir(parents=True, exist_ok=True)
        stage = temporary_sibling_dir(target)
        old: Path | None = None
        try:
            yield stage
            self._write_manifest(stage)
            os.chmod(stage, 0o777 & ~_umask())
            with _signals_held():
                if target.exists():
                    if self._existing_problem("--out") is not None:  # changed while the command ran
                        raise OutputError(f"{self.path}: changed while the command ran; nothing was replaced")
                    old = Path(tempfile.mkdtemp(prefix=f".{target.name}{_OLD}{_owner()}", dir=parent))
                    os.replace(target, old / "set")
                    os.replace(stage, target)
                else:
                    os.rename(stage, target)
        finally:
            with _signals_held():  # a Ctrl-C held back during the renames lands after the clean-up, not inside it
                shutil.rmtree(stage, ignore_errors=True)
                if old is not None:
                    shutil.rmtree(old, ignore_errors=True)

    def _write_manifest(self, stage: Path) -> None:
        files: list[dict[str, Any]] = []
        for name in sorted(os.listdir(stage)):
            f = stage / name
            if name == MANIFEST or not stat.S_ISREG(f.lstat().st_mode):
                continue
            files.append({"name": name, "bytes": f.stat().st_size, "sha256": _sha256(f)})
        manifest = {
            "command": self.command,
            "dualpose_version": _version(),
            "written_utc": datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds"),
            "files": files,
        }
        (stage / MANIFEST).write_text(json.dumps(manifest, indent=2) + "\n", encoding="utf-8")
