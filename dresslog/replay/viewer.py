"""`dresslog view`: a trial or .rrd in the Rerun viewer, native or web, or just saved.

An MCAP is first replayed into an .rrd (with the model when one is available,
otherwise ground truth alone), so the viewer always opens a complete file with
its default blueprint; the viewer itself is Rerun's own executable. `live_viewer`
gives `record --live` its stream: to a viewer spawned here or one already running.
"""

from __future__ import annotations

import contextlib
import os
import shutil
import signal
import socket
import stat
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import TYPE_CHECKING
from urllib.parse import quote, urlsplit

from dresslog.errors import DresslogError, TrialWriteError
from dresslog.io.files import NOT_REGULAR, atomic_path, check_output, no_such
from dresslog.io.reader import MAGIC, RRD_MAGIC, TrialReader
from dresslog.replay.pipeline import InferenceReport, replay_file
from dresslog.spec import Task
from dresslog.stops import stop_signals

if TYPE_CHECKING:
    import rerun as rr

#: The port a web viewer's data is served on unless asked (Rerun's own default), or taken.
GRPC_PORT = 9876
#: How long a viewer may take to stop on SIGTERM before it is killed.
VIEWER_STOP_S = 5.0
#: How often waiting for the viewer returns to Python, where Ctrl-C is noticed.
POLL_S = 0.2


#: Where `rr.spawn` starts a viewer, how much longer than `rr.spawn` itself waits (about
#: 10 s) it may take to listen there, and for how long it must then go on listening.
SPAWNED_URL = "rerun+http://127.0.0.1:9876/proxy"
SPAWN_GRACE_S = 3.0
SPAWN_SETTLE_S = 1.0


def live_viewer(task: Task | str, *, connect: str | None = None) -> rr.RecordingStream:
    """A recording stream of a `task` trial to a viewer: spawn a native one, or connect
    to a gRPC URL."""
    if connect is not None:
        check_reachable(connect)
    elif not has_display():
        # a viewer spawned here dies at once, and the stream to it then never lets go
        raise no_display(
            "stream to a viewer elsewhere with --connect, or record without --live "
            "and open the file with `dresslog view --web`"
        )
    import rerun as rr

    from dresslog.replay.blueprint import default_blueprint
    from dresslog.replay.rerun_sink import application_id

    rec = rr.RecordingStream(application_id(task))
    if connect is not None:
        rec.connect_grpc(connect, default_blueprint=default_blueprint(live=True))
        return rec
    with _runtime_dir_for_viewer():
        rec.spawn(default_blueprint=default_blueprint(live=True))
    # A viewer that cannot open its window listens for a moment, then exits, and the
    # stream to it fails: it must still listen SPAWN_SETTLE_S after it first did.
    deadline, since = time.monotonic() + SPAWN_GRACE_S, None
    while time.monotonic() < deadline:
        try:
            check_reachable(SPAWNED_URL, timeout=0.5)
            since = since or time.monotonic()
            if time.monotonic() - since >= SPAWN_SETTLE_S:
                return rec
        except DresslogError:
            since = None
        time.sleep(0.2)
    rec.disconnect()
    raise DresslogError(
        f"the Rerun viewer did not start (is DISPLAY={os.environ.get('DISPLAY', '')!r} a "
        "display you can open?); stream to a viewer elsewhere with --connect, or record "
        "without --live"
    )


def check_reachable(url: str, timeout: float = 2.0) -> None:
    """Fail in one line if no viewer listens at a `rerun+http://HOST:PORT/proxy` URL.

    Rerun itself would block for seconds on every call and then raise from a flush.
    """
    parts = urlsplit(url.removeprefix("rerun+"))
    try:
        port = parts.port or 9876  # raises for a port that is not a number in 0-65535
    except ValueError:
        port = None
    if parts.scheme not in ("http", "https") or not parts.hostname or port is None:
        raise DresslogError(f"{url!r} is not a Rerun address; give rerun+http://HOST:9876/proxy")
    try:
        socket.create_connection((parts.hostname, port), timeout=timeout).close()
    except OSError as err:
        raise DresslogError(
            f"no Rerun viewer answers at {url} ({err.strerror or err}); start one there "
            "(`rerun` listens on port 9876) or correct the address"
        ) from None


def has_display() -> bool:
    """Whether a native viewer can open: on Linux it needs an X11 or Wayland display."""
    names = ("DISPLAY", "WAYLAND_DISPLAY", "WAYLAND_SOCKET")
    return not sys.platform.startswith("linux") or any(os.environ.get(n) for n in names)


def no_display(instead: str, path: Path | None = None) -> DresslogError:
    """The error for a native viewer asked for where none can open."""
    return DresslogError(
        f"the Rerun viewer needs a display (neither DISPLAY nor WAYLAND_DISPLAY is set); {instead}",
        path=path,
    )


def save_rrd(
    path: str | Path,
    out: str | Path,
    *,
    model: str | Path | None = None,
    overwrite: bool = False,
    progress: bool = False,
) -> str:
    """Write what `view` would show to `out`; returns a one-line description. An existing
    `out` is replaced only with `overwrite`. `progress` draws the replayed steps on a
    progress bar when stderr is a terminal."""
    path, out = Path(path), Path(out)
    check_output(out, suffix=".rrd", overwrite=overwrite)
    if is_rrd(path, model):
        verify_rrd(path)  # a copy of a damaged recording would only hide the damage
        try:
            with atomic_path(out, overwrite=overwrite) as tmp:
                shutil.copyfile(path, tmp)
        except OSError as err:
            raise TrialWriteError(f"could not copy: {err.strerror}", path=out) from None
        return f"{path} -> {out}"
    report: InferenceReport = replay_file(
        path, model=model, require_model=model is not None, rrd=out, overwrite=overwrite,
        progress=progress,
    )  # fmt: skip
    return report.summary()


#: Why a model given with a recording is refused (the CLI's usage error says the same).
MODEL_FOR_RRD = (
    "is a Rerun recording, which already holds its estimates; --model applies only to an MCAP trial"
)


def is_rrd(path: str | Path, model: str | Path | None = None) -> bool:
    """Whether `path` is a Rerun recording (by name, or by its first bytes under another name).

    A recording already holds its estimate, so a `model` for it is refused, not ignored.
    """
    path = Path(path)
    if path.suffix == ".rrd":
        check_rrd(path)
    elif not _starts_with(path, RRD_MAGIC):
        return False
    if model is not None:
        raise DresslogError(MODEL_FOR_RRD, path=path)
    return True


def _starts_with(path: Path, magic: bytes) -> bool:
    if not path.is_file():  # a pipe would block the open, and give its bytes once
        return False  # the reader names what it is
    try:
        with path.open("rb") as stream:
            return stream.read(len(magic)) == magic
    except OSError:
        return False  # the reader names what is wrong with it


def check_rrd(path: str | Path) -> None:
    """A Rerun recording by its first bytes, or a one-line error (before a viewer chokes on it)."""
    path = Path(path)
    if path.exists() and not path.is_file() and not path.is_dir():
        raise DresslogError(NOT_REGULAR, path=path)
    if not path.is_file():
        raise DresslogError(no_such(path), path=path)
    if not _starts_with(path, RRD_MAGIC):
        raise DresslogError("not a Rerun recording (.rrd)", path=path)


def verify_rrd(path: Path) -> None:
    """Rerun's own check (`rerun rrd verify`) that the recording is whole and loads."""
    # -P: a `rerun.py` in the working folder is not Rerun
    where = _not_an_option(path)
    cmd = [sys.executable, "-P", "-m", "rerun", "rrd", "verify", where]
    done = subprocess.run(cmd, capture_output=True, text=True, check=False)
    said = (done.stdout + done.stderr).strip()
    if done.returncode == 0 and "1 file verified without error" in said:
        return
    if done.returncode == 0:  # rerun read no recording out of it
        said = "no recording in it could be read"
    reason = said.splitlines()[0] if said else f"exit status {done.returncode}"
    reason = reason.removeprefix("Error: ").replace(f'"{where}"', "").strip(" :-")
    raise DresslogError(
        f"is cut short or damaged, so it is not copied (rerun rrd verify: {reason[:160]}); "
        "write it again from its trial",
        path=path,
    )


def _stop(process: subprocess.Popen, group: bool) -> None:
    """Terminate the viewer's whole group; kill what is left after 5 s, or at a second Ctrl-C.

    Where the viewer is started by `python -m rerun` (not Linux), that is a wrapper that
    dies at once: what must be waited for is the viewer binary it started, which only
    the group still names.
    """

    def send(sig: int) -> None:
        with contextlib.suppress(ProcessLookupError):  # all gone already
            if group:
                os.killpg(process.pid, sig)
            else:
                process.send_signal(sig)

    send(signal.SIGTERM)
    try:
        deadline = time.monotonic() + VIEWER_STOP_S
        while _running(process, group) and time.monotonic() < deadline:
            time.sleep(0.05)
    except KeyboardInterrupt:
        pass  # asked twice: kill it now
    if _running(process, group):
        send(getattr(signal, "SIGKILL", signal.SIGTERM))
    process.wait()


def _wait_interruptibly(process: subprocess.Popen) -> str:
    """The viewer's stderr once it exits; Ctrl-C raises within a poll however it arrives.

    A signal the kernel delivers to another thread (numpy's BLAS threads) leaves a
    read without timeout blocked: only a return to Python runs the signal's handler.
    """
    while True:
        try:
            return process.communicate(timeout=POLL_S)[1] or ""
        except subprocess.TimeoutExpired:
            continue


def _running(process: subprocess.Popen, group: bool) -> bool:
    """Whether the viewer, or with `group` anything of its process group, is still there."""
    if process.poll() is None:
        return True
    if not group:
        return False
    try:
        os.killpg(process.pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


def _free_port(preferred: int = 0) -> int:
    """`preferred` if nothing listens there, else a port the system picks."""
    for port in (preferred, 0):
        with socket.socket() as probe:
            try:
                probe.bind(("127.0.0.1", port))
            except OSError:
                continue
            return int(probe.getsockname()[1])
    raise DresslogError("no free port on 127.0.0.1")


@contextlib.contextmanager
def _stopped_by_hangup_and_term() -> Iterator[None]:
    """A closed terminal (SIGHUP, unless ignored) or a kill (SIGTERM) stops the viewer as
    Ctrl-C does.

    The viewer runs in its own session, so these no longer reach it by themselves.
    """

    def interrupt(signum: int, frame: object) -> None:
        raise KeyboardInterrupt

    previous = {n: signal.signal(n, interrupt) for n in stop_signals()}
    try:
        yield
    finally:
        for n, handler in previous.items():
            signal.signal(n, handler)


def has_runtime_dir() -> bool:
    """Whether `XDG_RUNTIME_DIR` is one a viewer takes without complaint: a folder of this
    user's that only it may enter (0700), as the XDG base directory specification asks."""
    folder = os.environ.get("XDG_RUNTIME_DIR")
    if not hasattr(os, "getuid"):  # not a POSIX system, which has no such folder
        return True
    if not folder:
        return False
    try:
        st = Path(folder).stat()
    except OSError:
        return False
    return stat.S_ISDIR(st.st_mode) and st.st_uid == os.getuid() and not st.st_mode & 0o077


def viewer_env(private: Path) -> dict[str, str] | None:
    """The environment to start a viewer in: this one, where `XDG_RUNTIME_DIR` is unset or
    not valid (a headless machine, `su`, ssh) with it set to `private`, an empty folder of
    this user's, 0700. A viewer started without one writes `XDG_RUNTIME_DIR is invalid or
    not set` on the terminal. None: this one as it is."""
    if has_runtime_dir():
        return None
    private.chmod(0o700)
    return {**os.environ, "XDG_RUNTIME_DIR": str(private)}


@contextlib.contextmanager
def _runtime_dir_for_viewer() -> Iterator[None]:
    """`XDG_RUNTIME_DIR` a valid private folder while a viewer is spawned (by `rr.spawn`,
    which takes this process's environment); the folder is removed when dresslog exits."""
    if has_runtime_dir():
        yield
        return
    import atexit

    private = Path(tempfile.mkdtemp(prefix="dresslog-xdg-"))  # 0700
    atexit.register(shutil.rmtree, private, ignore_errors=True)
    before = os.environ.get("XDG_RUNTIME_DIR")
    os.environ["XDG_RUNTIME_DIR"] = str(private)
    try:
        yield
    finally:
        if before is None:
            del os.environ["XDG_RUNTIME_DIR"]
        else:
            os.environ["XDG_RUNTIME_DIR"] = before


def web_address(web_port: int, grpc_port: int) -> str:
    """The URL that opens the web viewer connected to the local gRPC server."""
    proxy = quote(f"rerun+http://127.0.0.1:{grpc_port}/proxy", safe="")
    return f"http://127.0.0.1:{web_port}/?url={proxy}"


#: Becomes the viewer binary (argv[2:]) once Linux is told to send it SIGTERM when its
#: parent, dresslog (argv[1]), dies, however it dies: a kill -9 would otherwise leave a
#: web viewer serving. exec keeps the parent-death signal; a parent already gone is seen.
_LAUNCH_TIED = (
    "import ctypes, os, signal, sys; "
    "ctypes.CDLL(None).prctl(1, signal.SIGTERM); "  # PR_SET_PDEATHSIG
    "os.getppid() == int(sys.argv[1]) or sys.exit('dresslog is gone'); "
    "os.execv(sys.argv[2], sys.argv[2:])"
)


def _rerun_launcher() -> list[str]:
    """How to start Rerun's viewer binary: tied to this process on Linux, else its wrapper."""
    import importlib.util

    spec = importlib.util.find_spec("rerun_cli")
    binary = Path(spec.origin).parent / "rerun" if spec and spec.origin else None
    if "RERUN_CLI_PATH" in os.environ:  # the override `python -m rerun` honours
        binary = Path(os.environ["RERUN_CLI_PATH"])
    if sys.platform == "linux" and binary is not None and os.access(binary, os.X_OK):
        return [sys.executable, "-P", "-c", _LAUNCH_TIED, str(os.getpid()), str(binary)]
    return [sys.executable, "-P", "-m", "rerun"]  # -P: not a `rerun.py` of the working folder


def _not_an_option(path: Path) -> str:
    """`path` as Rerun's argument: as given (Rerun takes UTF-8 paths only, and the
    working folder's may not be), `-x.rrd` as `./-x.rrd`, which is no option."""
    return f"{os.curdir}{os.sep}{path}" if str(path).startswith("-") else str(path)


def viewer_command(rrd: Path, *, web: bool, web_port: int, grpc_port: int) -> list[str]:
    """The `rerun` invocation: the native viewer, or a web viewer served on localhost only."""
    cmd = _rerun_launcher()
    if web:
        cmd += ["--serve-web", "--bind", "127.0.0.1"]
        cmd += ["--web-viewer-port", str(web_port), "--port", str(grpc_port)]
    return [*cmd, _not_an_option(rrd)]


def _run_viewer(cmd: list[str]) -> tuple[int, str]:
    """Run the viewer until it exits; its exit status and stderr.

    In its own process group: `python -m rerun` starts the viewer binary as a child,
    which terminating the wrapper alone would leave serving. With a private
    `XDG_RUNTIME_DIR` where this one is unset or invalid (`viewer_env`).
    """
    group = hasattr(os, "killpg")
    with (
        _stopped_by_hangup_and_term(),  # from before the viewer starts
        tempfile.TemporaryDirectory(prefix="dresslog-xdg-") as private,
    ):
        env = viewer_env(Path(private))
        process = subprocess.Popen(
            cmd, stderr=subprocess.PIPE, text=True, start_new_session=group, env=env
        )
        try:
            err = _wait_interruptibly(process)
        except KeyboardInterrupt:
            _stop(process, group)
            raise
    return process.returncode, err


def view_file(
    path: str | Path,
    *,
    model: str | Path | None = None,
    web: bool = False,
    web_port: int | None = None,
    grpc_port: int | None = None,
    echo: Callable[[str], None] = print,
    progress: bool = False,
) -> None:
    """Open `path` (MCAP trial or .rrd) in the viewer; blocks until it is closed.

    `progress` draws a trial's replayed steps on a progress bar when stderr is a terminal.

    Without `web_port` the web viewer's page takes port 9090, or a free port if that one
    is in use (a second `view --web`); without `grpc_port` the data it serves takes 9876,
    or a free one. Both listen on localhost only (an SSH tunnel forwards both). Ctrl-C, SIGTERM or
    SIGHUP stop the viewer, then reach the caller as KeyboardInterrupt; on Linux the
    viewer also stops when this process is killed outright.
    """
    path = Path(path)
    for port, option in ((web_port, "--port"), (grpc_port, "--grpc-port")):
        if port is not None and _free_port(port) != port:
            raise DresslogError(f"port {port} is in use; pass another {option} or leave it out")
    if web_port is not None and web_port == grpc_port:
        raise DresslogError(f"--port and --grpc-port are both {web_port}; give two ports")
    recording = path.is_file() and is_rrd(path, model)
    if not (recording or _starts_with(path, MAGIC)):  # a typo, a folder or a file of another
        # kind is named first, not the display, which would not cure it
        if path.is_dir() and (held := sorted(path.glob("*.mcap")) + sorted(path.glob("*.rrd"))):
            raise DresslogError(
                f"is a folder; view opens one trial or recording, such as {held[0]}", path=path
            )  # infer's advice, DIR/*.mcap, would be a usage error here
        TrialReader(path).open()  # names what the path is instead
    if not web and not has_display():  # checked before inferring, not after
        raise no_display(
            "serve it to a browser with --web, or write the recording with --save OUT.rrd", path
        )
    with contextlib.ExitStack() as stack:
        rrd = path
        if not recording:  # a recording is served as it is: no folder for it
            tmp = stack.enter_context(tempfile.TemporaryDirectory(prefix="dresslog-view-"))
            rrd = Path(tmp) / f"{path.stem}.rrd"
            echo(save_rrd(path, rrd, model=model, progress=progress))
        web_port = web_port or _free_port(9090)
        grpc_port = grpc_port or _free_port(GRPC_PORT if web_port != GRPC_PORT else 0)
        cmd = viewer_command(rrd, web=web, web_port=web_port, grpc_port=grpc_port)
        if web:
            echo(f"Web viewer: {web_address(web_port, grpc_port)}  (Ctrl-C to stop)")
        status, err = _run_viewer(cmd)
        if status != 0:
            last = err.strip().splitlines()[-1:] or ["no output"]
            hint = "" if web else "; without a display, try --web or --save"
            raise DresslogError(f"the Rerun viewer failed: {last[0][:200]}{hint}", path=path)
