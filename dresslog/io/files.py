"""Writing files: checked before any work, never half-written under a final name, hashed."""

from __future__ import annotations

import contextlib
import errno
import glob
import hashlib
import itertools
import os
import re
import shutil
import socket
import tempfile
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

from dresslog.errors import TrialWriteError

#: What a wrongly named output is told, by the suffix it needs.
_NAMES = {
    ".mcap": "a trial is an MCAP file; name it .mcap (.rrd is a Rerun recording)",
    ".rrd": "a Rerun recording is named .rrd (.mcap is a trial)",
    ".png": "a plot is a PNG image; name it .png",
    ".csv": "a table is a CSV file; name it .csv",
}
#: Names of recordings (a trial, a Rerun recording, ROS bags): `-o x.mcap` for a folder
#: (a model, a dataset, a sweep) is a slip for the trial or recording meant elsewhere.
RECORDING_SUFFIXES = (".mcap", ".rrd", ".bag", ".db3")


def named_as_recording(folder: str | Path, what: str) -> str | None:
    """Why `folder`, an output folder for `what` ("a model"), may not have its name: it
    is named as a recording (`x.mcap`); None if it is not."""
    folder = Path(folder)
    if (suffix := folder.suffix.lower()) not in RECORDING_SUFFIXES:
        return None
    return (
        f"{what} is a folder, not a {suffix} recording; name it without {folder.suffix} "
        f"(e.g. {folder.with_suffix('')})"
    )


def check_output(
    path: str | Path,
    source: str | Path | None = None,
    *,
    suffix: str | None = None,
    overwrite: bool = True,
) -> None:
    """Fail before any work if the output cannot be written or would replace `source`.

    `suffix` (".mcap", ".rrd", ".png" or ".csv") is the name the output must have: tools
    open a file by it. Without `overwrite` an existing file is refused (what took time to
    make). Missing folders above it are fine: the writer makes them (`make_folders`), so
    the nearest one that exists is checked.
    """
    path, source = Path(path), None if source is None else Path(source)
    folder = nearest_folder(path)
    if not folder.is_dir():  # a file, or a link to nothing, where a folder would go
        raise TrialWriteError(_not_a_folder(folder), path=path)
    if path.is_dir():
        raise TrialWriteError("is a folder; give a file name", path=path)
    check_writable(folder)
    if source is not None:
        check_not_source(path, source)
    if source is not None and source.is_dir() and resolved(path).is_relative_to(resolved(source)):
        raise TrialWriteError(
            f"is inside {source.name}, the folder being read; write it elsewhere", path=path
        )
    check_name_fits(path, temporary_path(path).name)
    if suffix is not None and path.name.lower() == suffix:  # `.mcap` is all suffix, no name
        raise TrialWriteError(f"give the file a name before {suffix}", path=path)
    if suffix is not None and path.suffix.lower() != suffix:
        raise TrialWriteError(_NAMES[suffix], path=path)
    if not overwrite and os.path.lexists(path):  # a symbolic link, even to nothing, too
        raise TrialWriteError("file exists; pass --overwrite to replace it", path=path)
    if suffix == ".rrd" and printable(path) != str(path):  # Rerun takes UTF-8 paths only
        raise TrialWriteError(
            "Rerun cannot write a file whose path is not UTF-8; name the recording otherwise",
            path=printable(path),
        )


def check_not_source(path: str | Path, source: str | Path, advice: str | None = None) -> None:
    """Fail if `path` is `source`, the file being read, under its own name or another
    (a symbolic link, `./t.mcap`); `advice` says what to do instead."""
    if resolved(path) == resolved(source):
        problem = f"would overwrite {Path(source).name}, the file being read"
        raise TrialWriteError(f"{problem}; {advice}" if advice else problem, path=path)


def check_output_folder(folder: str | Path, what: str) -> None:
    """Fail before any work if `folder`, to hold `what` ("the trials' outputs"), is a file,
    or would be made under one; a missing one is fine, the writers make it."""
    folder = Path(folder)
    if not (above := nearest_folder(folder / "_")).is_dir():  # `folder` itself, if it exists
        if above == folder and not folder.is_symlink():
            raise TrialWriteError(f"is a file; give a folder for {what}", path=folder)
        raise TrialWriteError(_not_a_folder(above), path=folder)


def nearest_folder(path: str | Path) -> Path:
    """`path`'s folder, or the nearest name above it that exists (what a missing folder
    would be made in); it may be a file, which the caller refuses."""
    path = Path(path)
    return next((f for f in path.parents if os.path.lexists(f)), path.parent)


def _not_a_folder(folder: Path) -> str:
    """Why `folder`, a name that exists, cannot hold an output, as the other commands say it."""
    if folder.is_symlink():
        try:
            folder.stat()
        except OSError as err:
            if err.errno == errno.ENOENT:
                return f"{folder} is a symbolic link to nothing; create its folder or give another"
            if err.errno == errno.ELOOP:
                return f"{folder} is a symbolic link that leads round in a loop; remove it"
    return f"{folder} is not a folder"


#: Why an input that is a pipe (`mkfifo`), a socket or a device is refused: it is read
#: from its start more than once (its magic, then the whole), and a pipe gives it once.
NOT_REGULAR = "is not a regular file (a pipe or a device); save it to a file first"


def no_such(path: str | Path, what: str = "file") -> str:
    """Why `path`, an input that is not there, cannot be read: `no such file`, or, for a
    symbolic link to nothing, where it leads (`ls` lists the link, so that misled)."""
    path = Path(path)
    if not path.is_symlink():
        return f"no such {what}"
    try:
        path.stat()
    except OSError as err:
        if err.errno == errno.ELOOP:
            return "is a symbolic link that leads round in a loop; remove it"
    return (
        f"is a symbolic link to {printable(path.readlink())}, which does not exist; mend the link"
    )


def make_folders(path: str | Path) -> list[Path]:
    """Make the missing folders above `path` (`-o runs/day1/trial.mcap`), as `train` and
    `generate` do; called just before its temporary is created, so a failed check makes none.

    Returns the folders made, outermost first: a write that fails hands them to
    `remove_folders`, so an interrupted run leaves no empty `runs/day1` behind. One
    another process made meanwhile is not counted.
    """
    path = Path(path)
    missing = list(itertools.takewhile(lambda f: not os.path.lexists(f), path.parents))
    made: list[Path] = []
    try:
        if not (above := nearest_folder(path)).is_dir():
            raise TrialWriteError(_not_a_folder(above), path=path)
        for folder in reversed(missing):
            try:
                folder.mkdir()
            except FileExistsError:
                if not folder.is_dir():
                    raise
            else:
                made.append(folder)
    except OSError as err:  # a file put there since the check, permissions
        remove_folders(made)
        raise TrialWriteError(f"cannot make its folder: {err.strerror or err}", path=path) from None
    return made


def remove_folders(made: list[Path]) -> None:
    """Remove the folders `make_folders` made that are still empty, deepest first; one that
    holds anything stays. Cleaning up must never raise over the real error."""
    for folder in reversed(made):
        with contextlib.suppress(OSError):
            folder.rmdir()


def resolved(path: str | Path) -> Path:
    """`path.resolve()`, with a symbolic link that loops refused in one line (Python 3.11
    raises RuntimeError for it, later ones OSError)."""
    try:
        return Path(path).resolve()
    except (RuntimeError, OSError) as err:
        if isinstance(err, RuntimeError) or err.errno == errno.ELOOP:
            problem = "is a symbolic link that leads round in a loop; remove it"
        else:
            problem = err.strerror or str(err)
        raise TrialWriteError(problem, path=path) from None


def _name_max(folder: Path) -> int:
    """The longest file name `folder`'s file system takes (255 where it cannot say)."""
    try:
        limit = os.pathconf(folder, "PC_NAME_MAX")
    except (OSError, ValueError, AttributeError):  # AttributeError: no pathconf on Windows
        return 255
    return limit if limit > 0 else 2**31  # -1: no limit it will tell


def check_name_fits(path: str | Path, longest: str) -> None:
    """Fail before any work if `longest`, a name written beside `path` (its temporary, a
    checkpoint), is too long for the folder's file system: the error names `path`."""
    if len(os.fsencode(longest)) > _name_max(nearest_folder(path)):  # bytes, undecodable too
        raise TrialWriteError(
            f"file name is too long once dresslog's working name beside it ({longest[:12]}...) "
            "is made from it; shorten it",
            path=path,
        )


def printable(path: str | Path) -> str:
    """`path` as text that UTF-8 (JSON, Rerun) can carry: a byte of a name that is not
    UTF-8 is written as an escape (`\\xff`)."""
    return os.fsencode(path).decode("utf-8", "backslashreplace")


def check_writable(folder: str | Path) -> None:
    """Fail before any work if nothing can be created in `folder` (permissions, read-only).

    A file is tried, not the permission bits read: root passes those everywhere, yet
    not a read-only mount.
    """
    try:
        tempfile.TemporaryFile(dir=folder).close()
    except OSError as err:
        raise TrialWriteError(f"cannot write here: {err.strerror}", path=folder) from None


def discard(path: str | Path) -> None:
    """Remove a temporary file if it is there; cleaning up must never raise over the real error."""
    with contextlib.suppress(OSError):
        Path(path).unlink(missing_ok=True)


_serial = itertools.count()


def temporary_path(path: str | Path) -> Path:
    """A fresh hidden name to write `path` under before it is renamed into place.

    Each call gives another name (process id and a serial), so two writers of one path
    never share a temporary; the last to finish wins, whole.
    """
    path = Path(path)
    return path.with_name(f".{path.name}.{os.getpid()}.{next(_serial)}.partial")


def is_temporary(name: str) -> bool:
    """Whether a file name is a temporary of `temporary_path` (this or an older dresslog's),
    such as a killed run leaves."""
    return re.fullmatch(r"\..+\.partial", name) is not None


def _gone(pid: int) -> bool:
    """Whether no process `pid` runs any more (a killed one not yet reaped, a zombie,
    writes no more either); one this user may not signal runs."""
    if pid <= 0 or pid == os.getpid():
        return False
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return True
    except (OverflowError, ValueError):  # a number no process can have
        return True
    except OSError:  # another user's
        return False
    try:  # Linux: field 3 of /proc/PID/stat is the state, after the name in parentheses
        stat = Path(f"/proc/{pid}/stat").read_bytes()
        return stat.rsplit(b")", 1)[1].split()[0] == b"Z"
    except (OSError, IndexError):
        return False


def discard_stale_temporaries(path: str | Path) -> list[Path]:
    """Remove the temporaries of `path` (`.NAME.PID.N.partial`, a file or a model's folder)
    that a killed run left behind: those whose process is gone. Called by every writer
    just before it makes its own, so a `kill -9` leaves its temporary until that name is
    next written, not for ever. Returns what was removed; cleaning up never raises."""
    path = Path(path)
    ours = re.compile(rf"\.{re.escape(path.name)}\.(\d+)\.\d+\.partial")
    removed = []
    try:
        found = sorted(path.parent.glob(f".{glob.escape(path.name)}.*.partial"))
    except OSError:
        return []
    for tmp in found:
        if (match := ours.fullmatch(tmp.name)) is None or not _gone(int(match.group(1))):
            continue
        if tmp.is_dir() and not tmp.is_symlink():
            shutil.rmtree(tmp, ignore_errors=True)
        else:
            discard(tmp)
        if not os.path.lexists(tmp):
            removed.append(tmp)
    return removed


def discard_temporaries(path: str | Path) -> None:
    """Remove every temporary this process has open for `path` (an exit that cannot unwind)."""
    path = Path(path)
    for tmp in path.parent.glob(f".{glob.escape(path.name)}.{os.getpid()}.*.partial"):
        discard(tmp)


def _sync_tree(path: Path) -> None:
    """`_sync` a file, or a folder's files and then the folder."""
    if path.is_dir() and not path.is_symlink():
        for inner in sorted(path.rglob("*")):
            if inner.is_file() and not inner.is_symlink():
                _sync(inner)
    _sync(path)


def _sync(path: Path) -> None:
    """Flush a file's bytes (a folder's entries) to the disk: a rename is written before
    the data it names, so a power cut after it could leave an empty file under the final
    name. A folder is not opened for syncing on Windows: skipped there."""
    try:
        fd = os.open(path, os.O_RDONLY)
    except OSError:  # a folder on Windows
        return
    try:
        os.fsync(fd)
    except OSError as err:  # a file system that cannot sync (EINVAL): nothing to do
        if err.errno not in (errno.EINVAL, errno.EBADF, errno.EROFS):
            raise
    finally:
        os.close(fd)


def put_in_place(tmp: str | Path, path: str | Path, *, overwrite: bool) -> None:
    """Rename the finished `tmp` to `path`, its bytes on the disk first and the folder's
    new entry after. Without `overwrite`, never over a file that appeared there meanwhile
    (another command's, written while this one worked): rename would replace it
    silently, a hard link refuses to."""
    tmp, path = Path(tmp), Path(path)
    _sync_tree(tmp)
    _rename(tmp, path, overwrite=overwrite)
    _sync(path.parent)


def _rename(tmp: Path, path: Path, *, overwrite: bool) -> None:
    if overwrite:
        tmp.replace(path)
        return
    try:
        os.link(tmp, path)
    except FileExistsError:
        pass
    except OSError:  # a file system without hard links: checked, then renamed
        if not os.path.lexists(path):
            tmp.replace(path)
            return
    else:
        discard(tmp)
        return
    discard(tmp)
    raise TrialWriteError(
        "was written by another command meanwhile; it is kept and this result dropped "
        "(pass --overwrite to replace it)",
        path=path,
    )


@contextmanager
def atomic_path(path: str | Path, *, overwrite: bool = True) -> Iterator[Path]:
    """Yield a temporary path beside `path`; rename it into place on success, else delete it
    and the folders made for it. Without `overwrite`, a file that appeared at `path`
    meanwhile is kept (`put_in_place`)."""
    path = Path(path)
    made = make_folders(path)
    discard_stale_temporaries(path)
    tmp = temporary_path(path)
    try:
        yield tmp
        put_in_place(tmp, path, overwrite=overwrite)
    except BaseException as err:
        discard(tmp)
        remove_folders(made)
        if isinstance(err, OSError) and err.filename is None:  # a full disk's names no file
            err.filename = str(path)
        raise


def sha256_file(path: str | Path) -> str:
    """Hex sha256 of a file's bytes."""
    with Path(path).open("rb") as stream:
        return hashlib.file_digest(stream, "sha256").hexdigest()


@contextmanager
def exclusive(lock: str | Path, command: str, output: str | Path | None = None) -> Iterator[None]:
    """Refuse a second `command` on `output` while one runs: an OS lock on the file `lock`
    (`filelock`: flock on POSIX, LockFileEx on Windows).

    The OS releases the lock when its process ends, however it ends, so a killed run
    leaves nothing to clean up; the file names the holder for the message. The file is
    removed while still held, and `filelock` takes a file removed under it for none.
    """
    from filelock import FileLock, Timeout

    lock = Path(lock)
    held = FileLock(lock, timeout=0, thread_local=False)
    try:
        held.acquire()
    except Timeout:
        try:
            holder = lock.read_text(errors="replace").strip()[:200]
        except OSError:
            holder = ""
        raise TrialWriteError(
            f"another `{command}` ({holder or 'starting'}) is writing it; wait for it to finish",
            path=output or lock.parent,
        ) from None
    try:
        with contextlib.suppress(OSError):  # read-only when another user made the file
            lock.write_text(f"{socket.gethostname()} pid {os.getpid()}")
        yield
    finally:
        with contextlib.suppress(OSError):  # while still held, so no one locks a removed file
            lock.unlink(missing_ok=True)
        held.release()
