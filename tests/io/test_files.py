"""Atomic writes reach the disk before their name does; one command's lock on an output
holds against another process, on any platform `filelock` serves."""

from __future__ import annotations

import os
import subprocess
import sys
import time
from pathlib import Path

import pytest

from dresslog.errors import TrialWriteError
from dresslog.io.files import atomic_path, exclusive, put_in_place

#: The sync tests name each synced descriptor's file by /proc (Linux).
_PROC = pytest.mark.skipif(not Path("/proc/self/fd").is_dir(), reason="names fds by /proc")


@_PROC
@pytest.mark.parametrize("overwrite", [True, False])
def test_a_file_is_synced_before_its_rename_and_the_folder_after(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, overwrite: bool
) -> None:
    """A rename can reach the disk before the data it names: a power cut then left an
    empty file under the final name."""
    done: list[str] = []
    real_fsync, real_replace, real_link = os.fsync, os.replace, os.link

    def fsync(fd: int) -> None:
        done.append("sync " + Path(f"/proc/self/fd/{fd}").readlink().name)
        real_fsync(fd)

    def rename(*args: object, **kwargs: object) -> None:
        done.append("rename")
        (real_replace if overwrite else real_link)(*args, **kwargs)  # type: ignore[operator]

    monkeypatch.setattr(os, "fsync", fsync)
    monkeypatch.setattr(os, "replace" if overwrite else "link", rename)
    (tmp := tmp_path / ".t.partial").write_bytes(b"trial")
    put_in_place(tmp, tmp_path / "t.mcap", overwrite=overwrite)
    assert done == ["sync .t.partial", "rename", f"sync {tmp_path.name}"]
    assert (tmp_path / "t.mcap").read_bytes() == b"trial"


@_PROC
def test_a_folder_written_atomically_has_its_files_synced(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    synced: list[str] = []
    real_fsync = os.fsync

    def fsync(fd: int) -> None:
        synced.append(Path(f"/proc/self/fd/{fd}").readlink().name)
        real_fsync(fd)

    monkeypatch.setattr(os, "fsync", fsync)
    with atomic_path(tmp_path / "model") as tmp:
        tmp.mkdir()
        (tmp / "weights").write_bytes(b"w")
    assert synced == ["weights", tmp.name, tmp_path.name]
    assert (tmp_path / "model" / "weights").read_bytes() == b"w"


_HOLD = """
import sys, time
from dresslog.io.files import exclusive
with exclusive(sys.argv[1], "dresslog generate"):
    print("held", flush=True)
    time.sleep(30)
"""


def test_a_lock_held_by_another_process_refuses_and_names_it(tmp_path: Path) -> None:
    lock = tmp_path / ".generate.lock"
    holder = subprocess.Popen(
        [sys.executable, "-c", _HOLD, str(lock)], stdout=subprocess.PIPE, text=True
    )
    try:
        assert holder.stdout is not None and holder.stdout.readline().strip() == "held"
        refused = pytest.raises(TrialWriteError, match=rf"pid {holder.pid}\) is writing it")
        with refused, exclusive(lock, "dresslog generate", tmp_path):
            pass
    finally:
        holder.kill()
        holder.wait()
        if holder.stdout is not None:
            holder.stdout.close()
    for _ in range(50):  # the OS lets go when the holder dies, however it dies
        try:
            with exclusive(lock, "dresslog generate", tmp_path):
                break
        except TrialWriteError:
            time.sleep(0.1)
    else:
        pytest.fail("the lock of a killed process was never released")
    assert not lock.exists()
