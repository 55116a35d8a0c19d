"""The `dresslog` command: help, version, `record` and `info` on a real trial."""

from __future__ import annotations

import json
import os
import re
import socket
import subprocess
import sys
from pathlib import Path

import click
import pytest
from click.testing import CliRunner

from dresslog import __version__
from dresslog.cli.main import COMMANDS, main
from dresslog.io.reader import read_trial
from dresslog.spec import Task, TrialSpec
from tests.conftest import SAMPLES, prints_warnings

SAMPLE = Path(__file__).resolve().parents[1] / "samples" / "gown.mcap"


def test_help_lists_the_commands() -> None:
    result = CliRunner().invoke(main, ["--help"])
    assert result.exit_code == 0
    listed = {line.split()[0] for line in result.output.split("Commands:")[1].splitlines() if line}
    assert listed == set(COMMANDS)


def test_version() -> None:
    result = CliRunner().invoke(main, ["--version"])
    assert result.exit_code == 0
    assert __version__ in result.output


def test_help_does_not_import_heavy_packages() -> None:
    code = (
        "import sys; from dresslog.cli.main import main\n"
        "try: main(['--help'])\n"
        "except SystemExit: pass\n"
        "print(sorted(m for m in ('torch', 'pybullet', 'rerun') if m in sys.modules))"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip().splitlines()[-1] == "[]"


def _option_help(command: str, option: str) -> str:
    """The help entry of `option` in `dresslog COMMAND --help`, on one line."""
    result = CliRunner().invoke(main, [command, "--help"])
    assert result.exit_code == 0, result.output
    entry = re.search(rf"^  (?:-\w, )?{option}\b.*?(?=^  -)", result.output, re.M | re.S)
    assert entry, result.output
    return " ".join(entry.group().split())


def test_every_option_has_help() -> None:
    for name in COMMANDS:
        command = main.get_command(click.Context(main), name)
        assert command is not None
        bare = [p.name for p in command.params if isinstance(p, click.Option) and not p.help]
        assert not bare, f"{name}: {bare}"


def test_record_help_states_the_default_duration() -> None:
    entry = _option_help("record", "--duration")
    default = TrialSpec.model_fields["duration"].default
    assert re.search(rf"default: \(?{default:g}\b", entry), entry


@pytest.mark.parametrize("spelling", ["-o", "--out", "--output"])
def test_the_output_option_takes_every_spelling(tmp_path: Path, spelling: str) -> None:
    """record/convert/infer named it --output, generate/train/sweep --out: both work in all."""
    rrd = tmp_path / "t.rrd"
    inferred = CliRunner().invoke(main, ["infer", str(SAMPLE), spelling, str(rrd)])
    assert inferred.exit_code == 0 and rrd.is_file(), inferred.output
    (taken := tmp_path / "taken").mkdir()
    (taken / "notes.txt").write_text("")  # not a model: train refuses it, naming it
    trained = CliRunner().invoke(main, ["train", str(tmp_path), spelling, str(taken)])
    assert trained.exit_code == 1 and str(taken) in trained.output, trained.output


def test_record_takes_m_for_model(tmp_path: Path) -> None:
    args = ["record", "--task", "gown", "-m", "m", "-o", str(tmp_path / "t.mcap")]
    result = CliRunner().invoke(main, args)
    assert result.exit_code == 2 and "use it with --live" in result.output


def test_info_reports_task_steps_channels_and_spec(make_trial) -> None:
    path, _ = make_trial(steps=120)
    result = CliRunner().invoke(main, ["info", str(path)])
    assert result.exit_code == 0, result.output
    assert "task      gown" in result.output
    assert "steps     120 over 1.20 s at 100 Hz" in result.output  # 120 steps of 10 ms
    assert "/limb/force_map" in result.output and "ground truth yes" in result.output
    assert "seed 11" in result.output


def test_info_json_is_machine_readable(make_trial) -> None:
    path, _ = make_trial(steps=30)
    result = CliRunner().invoke(main, ["info", "--json", str(path)])
    assert result.exit_code == 0, result.output
    summary = json.loads(result.output)
    assert summary["task"] == "gown" and summary["steps"] == 30
    assert summary["rate_hz"] == 100.0 and summary["limb_points"] == 300
    assert summary["has_ground_truth"] and not summary["has_estimate"]
    counts = {c["topic"]: c["count"] for c in summary["channels"]}
    assert counts["/ee/wrench"] == 30 and counts["/limb/points"] == 1
    assert summary["metadata"]["spec"]["seed"] == 11


@pytest.mark.slow
def test_record_makes_the_readme_trial_and_never_replaces_a_file_unasked(tmp_path: Path) -> None:
    out = tmp_path / "trial.mcap"
    args = ["record", "--task", "gown", "--seed", "42", "-o", str(out)]
    result = CliRunner().invoke(main, args)
    assert result.exit_code == 0, result.output
    assert result.output.startswith("outcome=") and "steps=700" in result.output
    ours, sample = read_trial(out).metadata, read_trial(SAMPLE).metadata
    assert ours.spec == sample.spec  # the README's main job records the bundled sample's trial
    before = out.read_bytes()
    again = CliRunner().invoke(main, args)
    assert again.exit_code == 1
    assert again.output.strip() == f"Error: {out}: file exists; pass --overwrite to replace it"
    assert out.read_bytes() == before
    other = ["record", "--task", "gown", "--seed", "5", "--duration", "0.1", "-o", str(out)]
    assert CliRunner().invoke(main, [*other, "--overwrite"]).exit_code == 0
    assert read_trial(out).metadata.spec.seed == 5  # replaced


@pytest.mark.parametrize(
    "args",
    [
        ["record", "--task", "gown", "--duration", "0.1", "--offset", "0.01", "-0.02", "0.03"],
        ["convert", str(SAMPLE), "--task", "gown"],
    ],
    ids=["record", "convert"],
)
def test_a_trial_not_named_mcap_is_refused_before_any_work(tmp_path: Path, args: list[str]) -> None:
    out = tmp_path / "t.txt"
    result = CliRunner().invoke(main, [*args, "-o", str(out)])
    assert result.exit_code == 1 and "a trial is an MCAP file; name it .mcap" in result.output
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("command", ["record", "convert"])
def test_a_trial_into_a_missing_folder_makes_the_folder_as_train_and_generate_do(
    tmp_path: Path, command: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Both used to refuse a missing folder ("folder does not exist; create it first"); they
    make it, and a run that fails or is interrupted removes the folders it made, where it
    left them behind empty. A file, or a link to nothing, where a folder goes is one line."""
    (csv := tmp_path / "ft.csv").write_text(
        "time,fx,fy,fz,tx,ty,tz,vx,vy,vz\n"
        + "".join(f"{t / 100},0,0,0,0,0,0,0,0,0\n" for t in range(50))
    )
    args = {
        "record": ["record", "--task", "gown", "--duration", "0.1"],
        "convert": ["convert", str(csv), "--task", "gown"],
    }[command]
    out = tmp_path / "runs" / "day1" / "trial.mcap"
    result = CliRunner().invoke(main, [*args, "-o", str(out)])
    assert result.exit_code == 0, result.output
    assert [p.name for p in out.parent.iterdir()] == ["trial.mcap"]  # no temporary left over
    assert read_trial(out).metadata.task is Task.GOWN
    (blocker := tmp_path / "notes").write_text("")  # a file where a folder would go
    under = blocker / "day2" / "trial.mcap"
    refused = CliRunner().invoke(main, [*args, "-o", str(under)])
    assert refused.exit_code == 1
    assert refused.output == f"Error: {under}: {blocker} is not a folder\n"
    assert blocker.read_text() == ""
    (dangling := tmp_path / "linked").symlink_to(tmp_path / "nowhere")
    linked = CliRunner().invoke(main, [*args, "-o", str(dangling / "day3" / "trial.mcap")])
    assert linked.exit_code == 1
    assert linked.output.endswith(
        f": {dangling} is a symbolic link to nothing; create its folder or give another\n"
    )

    def interrupted(*_: object) -> None:
        raise KeyboardInterrupt

    monkeypatch.setattr("dresslog.io.writer.TrialWriter.write_twist", interrupted)
    (kept := tmp_path / "kept").mkdir()  # existed before: stays, with what it holds
    (kept / "notes.txt").write_text("")
    for folder in (tmp_path / "new", kept):
        stopped = CliRunner().invoke(main, [*args, "-o", str(folder / "a" / "b" / "t.mcap")])
        assert stopped.exit_code == 1 and "Aborted!" in stopped.output, stopped.output
    assert not (tmp_path / "new").exists()
    assert [p.name for p in kept.iterdir()] == ["notes.txt"]


def test_infer_and_view_save_interrupted_remove_the_folders_they_made(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The Rerun recording's folders (made as it closes) and view --save's copy's were left."""
    rrd = tmp_path / "g.rrd"
    assert (
        CliRunner().invoke(main, ["infer", str(SAMPLES / "gown.mcap"), "-o", str(rrd)]).exit_code
        == 0
    )

    def interrupted(*_: object) -> None:
        raise KeyboardInterrupt

    monkeypatch.setattr("dresslog.replay.rerun_sink.RerunSink.flush", interrupted)
    args = ["infer", str(SAMPLES / "gown.mcap"), "-o", str(tmp_path / "a" / "b" / "g.rrd")]
    assert "Aborted!" in CliRunner().invoke(main, args).output
    monkeypatch.undo()  # the estimate copy is finished, and the recording then fails
    monkeypatch.setattr("dresslog.replay.rerun_sink.RerunSink.commit", interrupted)
    args = [*args[:2], "-o", str(rrd), "--mcap-out", str(tmp_path / "d" / "e" / "g.mcap")]
    args += ["--overwrite"]
    assert "Aborted!" in CliRunner().invoke(main, args).output
    monkeypatch.setattr("shutil.copyfile", interrupted)
    saved = CliRunner().invoke(main, ["view", str(rrd), "--save", str(tmp_path / "c" / "g.rrd")])
    assert "Aborted!" in saved.output
    assert sorted(p.name for p in tmp_path.iterdir()) == ["g.rrd"]


def test_record_model_without_live_and_an_upper_case_suffix(tmp_path: Path) -> None:
    args = ["record", "--task", "gown", "--duration", "0.1"]
    unused = CliRunner().invoke(main, [*args, "--model", "m", "-o", str(tmp_path / "a.mcap")])
    assert unused.exit_code == 2 and "use it with --live" in unused.output
    upper = CliRunner().invoke(main, [*args, "-o", str(tmp_path / "B.MCAP")])
    assert upper.exit_code == 0 and read_trial(tmp_path / "B.MCAP").metadata.spec.duration == 0.1


@pytest.mark.parametrize(
    "mount", [["--sensor-offset", "0", "0", "0.05"], ["--sensor-rotation", "0", "0", "0", "1"]]
)
def test_a_sensor_mount_without_a_gripper_frame_is_a_usage_error(tmp_path: Path, mount) -> None:
    out = tmp_path / "t.mcap"
    args = ["convert", str(SAMPLE), "--task", "gown", "-o", str(out), *mount]
    result = CliRunner().invoke(main, [*args, "--wrench-frame", "world"])
    assert result.exit_code == 2 and "Usage:" in result.output
    assert f"{mount[0]} places a sensor on the gripper: use it with --wrench-frame pose" in (
        result.output
    )
    assert not out.exists()


def test_record_options_reach_the_spec(tmp_path: Path) -> None:
    out = tmp_path / "t.mcap"
    args = ["record", "--task", "shorts", "--seed", "2", "--speed", "0.2", "--duration", "0.1"]
    args += ["--offset", "0.01", "-0.02", "0.03", "--rotation", "x", "5", "-o", str(out)]
    assert CliRunner().invoke(main, args).exit_code == 0
    spec = read_trial(out).metadata.spec
    assert (spec.seed, spec.speed, spec.duration) == (2, 0.2, 0.1)
    assert spec.limb_offset == (0.01, -0.02, 0.03)
    assert (spec.limb_rotation.axis, spec.limb_rotation.degrees) == ("x", 5.0)
    assert spec.sim.simulator == 9  # the current simulator's
    older = ["record", "--task", "shorts", "--duration", "0.1", "--simulator", "v7"]
    assert CliRunner().invoke(main, [*older, "-o", str(out), "--overwrite"]).exit_code == 0
    v7 = read_trial(out).metadata.spec.sim
    assert (v7.simulator, v7.wrench_from, v7.damping_stiffness) == (8, "constraint", 1.0)


@pytest.mark.slow
def test_generate_draws_new_folders_on_v9_and_keeps_an_older_ones(tmp_path: Path) -> None:
    """A folder of simulator v7 (its wrench from the constraint, no simulator named in
    its manifest) is extended as it was made, with --simulator v7; without, one line
    says so."""
    import json

    from dresslog.dataset import load_manifest

    runner = CliRunner()
    args = ["generate", "--task", "gown", "--duration", "0.1", "--test-fraction", "0", "-q"]
    new, old = tmp_path / "new", tmp_path / "old"
    assert runner.invoke(main, [*args, "--trials", "2", "-o", str(new)]).exit_code == 0
    assert load_manifest(new).overrides["sim"] == {"simulator": 9}
    v7 = [*args, "--simulator", "v7", "-o", str(old)]
    assert runner.invoke(main, [*v7, "--trials", "2"]).exit_code == 0
    # as a folder made before v9 says it: no simulator, no sim fields at all
    raw = json.loads((old / "manifest.json").read_text())
    del raw["overrides"]["sim"]
    for entry in raw["trials"]:
        del entry["spec"]["sim"]["simulator"]
        del entry["spec"]["sim"]["wrench_from"]
    (old / "manifest.json").write_text(json.dumps(raw))
    assert load_manifest(old).overrides["sim"] == {"simulator": 8, "wrench_from": "constraint"}
    result = runner.invoke(main, [*args, "--trials", "3", "-o", str(old)])
    assert result.exit_code == 1
    assert result.output.endswith(
        "fixed spec fields duration=0.1, sim={'simulator': 8, 'wrench_from': 'constraint'}, not "
        "duration=0.1, sim={'simulator': 9}; use another folder or the same options (a folder "
        "of simulator v7: --simulator v7)\n"
    )
    assert runner.invoke(main, [*v7, "--trials", "3"]).exit_code == 0
    made = load_manifest(old)
    assert len(made.trials) == 3
    assert {e.spec.sim.wrench_from for e in made.trials} == {"constraint"}


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="X11/Wayland are Linux's")
def test_record_live_without_a_display_says_so_and_writes_nothing(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    for name in ("DISPLAY", "WAYLAND_DISPLAY", "WAYLAND_SOCKET"):
        monkeypatch.delenv(name, raising=False)
    out = tmp_path / "live.mcap"
    args = ["record", "--task", "gown", "--duration", "0.2", "--live", "-o", str(out)]
    result = CliRunner().invoke(main, args)
    assert result.exit_code == 1
    assert (
        result.output.startswith("Error: the Rerun viewer needs a display")
        and "--connect" in result.output
        and "view --web" in result.output
    )
    assert list(tmp_path.iterdir()) == []


@pytest.mark.slow
@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="X11/Wayland are Linux's")
def test_record_live_with_a_display_that_does_not_open_says_so_and_writes_nothing(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A stale DISPLAY (an ssh session's, long closed): the spawned viewer exits at once."""
    with socket.socket() as probe:
        if probe.connect_ex(("127.0.0.1", 9876)) == 0:
            pytest.skip("a viewer already listens on 9876, where --live would stream")
    for name in ("WAYLAND_DISPLAY", "WAYLAND_SOCKET"):
        monkeypatch.delenv(name, raising=False)
    monkeypatch.setenv("DISPLAY", ":97")  # no X server there
    out = tmp_path / "live.mcap"
    args = ["record", "--task", "gown", "--duration", "0.2", "--live", "-o", str(out)]
    result = CliRunner().invoke(main, args)
    assert result.exit_code == 1, result.output
    assert "Error: the Rerun viewer did not start (is DISPLAY=':97'" in result.output
    assert "Traceback" not in result.output and list(tmp_path.iterdir()) == []


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@pytest.mark.slow
def test_record_connect_streams_to_a_viewer_elsewhere_without_a_display(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    import rerun as rr

    for name in ("DISPLAY", "WAYLAND_DISPLAY", "WAYLAND_SOCKET"):
        monkeypatch.delenv(name, raising=False)
    server = rr.RecordingStream("dresslog-test-server")  # stands in for the remote viewer
    url = rr.serve_grpc(grpc_port=_free_port(), recording=server)
    out = tmp_path / "live.mcap"
    args = ["record", "--task", "gown", "--duration", "0.2", "--connect", url, "-o", str(out)]
    result = CliRunner().invoke(main, args)
    server.disconnect()
    assert result.exit_code == 0, result.output
    # the bundled model ran beside the simulation, scored as `infer` scores a trial
    assert re.search(
        r"^estimate RMSE \S+ N \(all-zero estimate \S+ N(, ratio \S+)?\)$", result.output, re.M
    ), result.output
    assert read_trial(out).force_map.forces.shape == (20, 300)


@pytest.mark.parametrize(
    ("url", "message"),
    [
        ("rerun+http://127.0.0.1:{port}/proxy", "no Rerun viewer answers at rerun+http"),
        ("127.0.0.1:{port}", "is not a Rerun address; give rerun+http://HOST:9876/proxy"),
        ("rerun+http://127.0.0.1:port/proxy", "is not a Rerun address"),
        ("rerun+http://127.0.0.1:99999/proxy", "is not a Rerun address"),
        ("", "'' is not a Rerun address"),
    ],
    ids=["nobody-listens", "no-scheme", "port-not-a-number", "port-too-large", "empty"],
)
def test_record_connect_to_no_viewer_is_one_line_and_writes_nothing(
    tmp_path: Path, url: str, message: str
) -> None:
    out = tmp_path / "live.mcap"
    url = url.format(port=_free_port())
    args = ["record", "--task", "gown", "--duration", "0.2", "--connect", url, "-o", str(out)]
    result = CliRunner().invoke(main, args)
    assert result.exit_code == 1
    lines = result.output.strip().splitlines()
    assert len(lines) == 1 and message in lines[0], result.output
    assert list(tmp_path.iterdir()) == []


@prints_warnings
def test_record_connect_to_something_not_a_viewer_keeps_the_trial_and_says_so(
    tmp_path: Path,
) -> None:
    """It answers and takes the stream, which fails only as it is flushed at the end: the
    trial is whole by then, so it is kept (a long simulation is not thrown away for a
    viewer closed partway), with a warning rather than an error saying nothing was written."""
    import http.server
    import threading

    server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), http.server.BaseHTTPRequestHandler)
    threading.Thread(target=server.serve_forever, daemon=True).start()
    out = tmp_path / "live.mcap"
    url = f"rerun+http://127.0.0.1:{server.server_address[1]}/proxy"
    args = ["record", "--task", "gown", "--duration", "0.2", "--connect", url]
    try:
        result = CliRunner().invoke(main, [*args, "-o", str(out)])
    finally:
        server.shutdown()
        server.server_close()
    assert result.exit_code == 0, result.output
    assert "Warning: the Rerun viewer went away before the live view ended" in result.stderr
    assert read_trial(out).force_map.forces.shape == (20, 300)
    assert list(tmp_path.iterdir()) == [out]


@pytest.mark.parametrize(
    ("option", "message"),
    [
        (["--duration", "inf"], "invalid duration: Input should be a finite number"),
        (["--duration", "nan"], "invalid duration: Input should be a finite number"),
        (["--duration", "1e9"], "invalid duration: Input should be less than or equal to 3600"),
        (["--duration", "0.004"], "invalid duration: at least two recorded steps, 0.02 s"),
        (["--rotation", "y", "88"], "the fist lies inside the rest of the arm"),
    ],
    ids=["duration-inf", "duration-nan", "duration-huge", "duration-tiny", "fist-on-the-shoulder"],
)
def test_record_refuses_a_setting_out_of_range_before_simulating(
    tmp_path: Path, option: list[str], message: str
) -> None:
    out = tmp_path / "t.mcap"
    result = CliRunner().invoke(main, ["record", "--task", "gown", *option, "-o", str(out)])
    assert result.exit_code == 1 and message in result.output, result.output
    assert not out.exists()


@pytest.mark.parametrize(
    ("option", "message"),
    [
        (["--speed", "5"], "Invalid value for '--speed': 5.0 is not in the range 0<x<=1."),
        (["--speed", "nan"], "Invalid value for '--speed': nan is not in the range 0<x<=1."),
        (["--offset", "nan", "0", "0"], "'--offset': nan is not in the range -10.0<=x<=10.0."),
        (["--offset", "0", "1e16", "0"], "'--offset': 1e+16 is not in the range -10.0<=x<=10."),
        (["--rotation", "z", "999"], "'--rotation': 999.0 is not in the range -90<=x<=90."),
        (["--rotation", "x", "-nan"], "'--rotation': nan is not in the range -90<=x<=90."),
    ],
    ids=["speed", "speed-nan", "offset-nan", "offset-huge", "rotation", "rotation-nan"],
)
def test_record_names_an_option_out_of_its_range_as_a_usage_error(
    tmp_path: Path, option: list[str], message: str
) -> None:
    """As every command does for an option's value (`generate --trials 0`), not exit 1 with
    the spec field's name (`invalid limb_rotation.degrees: ...`)."""
    out = tmp_path / "t.mcap"
    result = CliRunner().invoke(main, ["record", "--task", "gown", *option, "-o", str(out)])
    assert result.exit_code == 2 and message in result.output, result.output
    assert "Usage: " in result.output and not out.exists()


#: Each command with what it requires, so that only the value under test is wrong.
_BASE = {
    "convert": ["convert", "{tmp}/log.csv", "-o", "{tmp}/t.mcap", "--task", "gown"],
    "generate": ["generate", "--task", "gown", "--trials", "2", "-o", "{tmp}/data"],
    "train": ["train", "{tmp}/data", "-o", "{tmp}/model"],
    "sweep": ["sweep", "{tmp}/model", "--speeds", "0.2", "-o", "{tmp}/sweep"],
}


@pytest.mark.parametrize(
    ("command", "option", "values"),
    [
        ("convert", "--tare", ["nan"]),
        ("convert", "--tare", ["inf"]),
        ("convert", "--rotate", ["0", "0", "nan", "1"]),
        ("convert", "--sensor-rotation", ["0", "0", "0", "-inf"]),
        ("convert", "--translate", ["0.1", "inf", "0"]),
        ("convert", "--sensor-offset", ["nan", "0", "0"]),
        ("convert", "--sensor-offset", ["0", "0", "1e300"]),  # torque beyond float32
        ("convert", "--translate", ["0", "0", "2000"]),
        ("generate", "--test-fraction", ["nan"]),
        ("generate", "--duration", ["nan"]),
        ("generate", "--duration", ["inf"]),
        ("generate", "--duration", ["1e9"]),
        ("sweep", "--duration", ["nan"]),
        ("sweep", "--duration", ["5000"]),
        ("train", "--lr", ["nan"]),
        ("train", "--lr", ["inf"]),
        ("sweep", "--speeds", ["5"]),
        ("sweep", "--speeds", ["0.2,nan"]),
        ("sweep", "--speeds", ["-inf"]),
        ("sweep", "--rotations", ["z:999"]),
        ("sweep", "--rotations", ["y:-15,x:nan"]),
        ("sweep", "--rotations", ["z:inf"]),
        ("generate", "--trials", ["1000001"]),
        ("sweep", "--sequences", ["2000000"]),
    ],
    ids=lambda v: " ".join(v) if isinstance(v, list) else v,
)
def test_every_command_names_a_number_out_of_its_range_as_a_usage_error(
    tmp_path: Path, command: str, option: str, values: list[str]
) -> None:
    """A value click can check (nan and inf too) is its usage error (exit 2, naming the option
    and its range), as record's --speed is, not the library's exit 1 after start-up."""
    args = [a.replace("{tmp}", str(tmp_path)) for a in _BASE[command]]
    result = CliRunner().invoke(main, [*args, option, *values])
    assert result.exit_code == 2, result.output
    assert f"Invalid value for '{option}'" in result.output and "Usage: " in result.output
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize(
    ("option", "message"),
    [
        (["--lr", "10"], "'--lr': 10.0 is not in the range 0<x<=1."),
        (["--hidden", "5000"], "'--hidden': 5000 is not in the range 1<=x<=1024."),
        (["--layers", "9"], "'--layers': 9 is not in the range 1<=x<=8."),
    ],
    ids=["lr", "hidden", "layers"],
)
def test_train_refuses_a_network_or_learning_rate_beyond_any_use_as_a_usage_error(
    tmp_path: Path, option: list[str], message: str
) -> None:
    """They had no ceiling, so a slip (--lr 10, --hidden 5000) went on to load the trials
    and train; the bundled models' settings are well inside."""
    args = ["train", str(tmp_path / "data"), "-o", str(tmp_path / "model"), *option]
    result = CliRunner().invoke(main, args)
    assert result.exit_code == 2 and f"Error: Invalid value for {message}" in result.output
    assert list(tmp_path.iterdir()) == []
    for task in Task:
        card = json.loads((SAMPLES / "models" / task.value / "card.json").read_text())
        bundled = ["--hidden", str(card["hidden"]), "--layers", str(card["layers"]),
                   "--lr", str(card["hyperparameters"]["lr"])]  # fmt: skip
        result = CliRunner().invoke(main, [*args[:4], *bundled])
        assert result.exit_code == 1 and "Invalid value" not in result.output, result.output


@pytest.mark.skipif(sys.platform == "win32", reason="SIGTERM ends a process outright there")
@pytest.mark.parametrize("sent", ["SIGTERM", "SIGHUP", "SIGHUP-under-nohup"])
def test_a_killed_record_leaves_no_file(tmp_path: Path, sent: str) -> None:
    """`kill PID` (a scheduler's timeout, `docker stop`) or a closed terminal stops a
    command as Ctrl-C does; one started with `nohup` (SIGHUP ignored) goes on."""
    import os
    import signal
    import time

    out = tmp_path / "t.mcap"
    # as from a terminal, or `nohup`; the former even when the tests run under nohup
    nohup = "nohup" in sent
    hup = "SIG_IGN" if nohup else "SIG_DFL"
    entry = (
        f"import signal, sys; signal.signal(signal.SIGHUP, signal.{hup}); "
        "from dresslog.cli.main import run; "
        "sys.argv[0] = 'dresslog'; run()"
    )
    duration = "3" if nohup else "30"
    args = ["record", "--task", "gown", "--duration", duration, "-o", str(out)]
    run = subprocess.Popen([sys.executable, "-c", entry, *args], stderr=subprocess.PIPE)
    deadline = time.monotonic() + 60
    while not list(tmp_path.glob(".t.mcap.*.partial")) and time.monotonic() < deadline:
        time.sleep(0.05)
    time.sleep(0.5)  # into the simulation, with messages written
    os.kill(run.pid, getattr(signal, sent.split("-")[0]))
    _, err = run.communicate(timeout=60)
    if nohup:
        assert run.returncode == 0 and read_trial(out).metadata.spec.duration == 3, err
        return
    assert run.returncode != 0 and b"Traceback" not in err, err
    assert list(tmp_path.iterdir()) == []


def test_an_output_named_only_by_its_suffix_is_told_to_have_a_name(tmp_path: Path) -> None:
    out = tmp_path / ".rrd"
    result = CliRunner().invoke(main, ["infer", str(SAMPLE), "-o", str(out)])
    assert result.output == f"Error: {out}: give the file a name before .rrd\n"
    assert result.exit_code == 1 and list(tmp_path.iterdir()) == []


def test_a_name_too_long_for_its_temporary_is_one_line_naming_the_output(tmp_path: Path) -> None:
    """The file is written under a longer hidden name first: that one must fit too."""
    out = tmp_path / ("a" * 240 + ".rrd")
    result = CliRunner().invoke(main, ["infer", str(SAMPLE), "-o", str(out)])
    assert result.exit_code == 1 and result.output.startswith(f"Error: {out}: file name is too")
    assert list(tmp_path.iterdir()) == []


@pytest.mark.skipif(sys.platform != "linux", reason="names that are not UTF-8: Linux's bytes")
def test_a_file_name_that_is_not_utf8_is_one_line_not_a_traceback(tmp_path: Path) -> None:
    """Every writer raised UnicodeEncodeError on such a name (check_name_fits, Rerun)."""
    from tests.conftest import write_synthetic_trial

    trial = tmp_path / os.fsdecode(b"tr\xffial.mcap")
    write_synthetic_trial(trial, Task.GOWN, steps=20)
    refused = CliRunner().invoke(main, ["infer", str(trial)])  # its .rrd beside it
    assert refused.exit_code == 1 and "tr\\xffial.rrd: Rerun cannot write a file" in refused.output
    out = tmp_path / "fine.rrd"  # printed as a terminal takes it (CliRunner's output is strict)
    code = "import sys; from dresslog.cli.main import main; main(sys.argv[1:])"
    args = [sys.executable, "-c", code, "infer", os.fsencode(trial), "-o", str(out)]
    done = subprocess.run(args, capture_output=True)
    assert done.returncode == 0 and out.is_file(), done.stderr
    csv = tmp_path / os.fsdecode(b"ft\xff.csv")
    csv.write_text("time,fx,fy,fz,tx,ty,tz,vx,vy,vz\n" + "0,0,0,0,0,0,0,0,0,0\n")
    args = ["convert", str(csv), "-o", str(tmp_path / "c.mcap"), "--task", "gown"]
    converted = CliRunner().invoke(main, args)
    assert converted.exit_code == 1 and "its name is not UTF-8" in converted.output


@pytest.mark.skipif(sys.platform == "win32", reason="symbolic links need privileges there")
def test_an_output_that_is_a_looping_symlink_is_one_line(tmp_path: Path) -> None:
    """Path.resolve() raised RuntimeError on it: a traceback from infer, generate, sweep."""
    loop = tmp_path / "loop.rrd"
    loop.symlink_to(loop)
    result = CliRunner().invoke(main, ["infer", str(SAMPLES / "gown.mcap"), "-o", str(loop)])
    assert result.exit_code == 1 and "a symbolic link that leads round in a loop" in result.output
    folder = tmp_path / "data"
    folder.symlink_to(folder)
    result = CliRunner().invoke(
        main, ["generate", "--task", "gown", "--trials", "1", "-o", str(folder)]
    )
    assert result.exit_code == 1 and "leads round in a loop" in result.output


@pytest.mark.skipif(sys.platform != "linux", reason="names that are not UTF-8: Linux's bytes")
def test_a_working_folder_whose_name_is_not_utf8(tmp_path: Path, monkeypatch) -> None:
    """Rerun was handed the absolute path (it panics on one not UTF-8), convert stored the
    resolved path in the JSON metadata, info --json the name: tracebacks or a refusal."""
    here = tmp_path / os.fsdecode(b"caf\xe9")
    here.mkdir()
    monkeypatch.chdir(here)
    assert (
        CliRunner().invoke(main, ["infer", str(SAMPLES / "gown.mcap"), "-o", "g.rrd"]).exit_code
        == 0
    )
    saved = CliRunner().invoke(main, ["view", "g.rrd", "--save", "copy.rrd"])
    assert saved.exit_code == 0, saved.output
    Path("ft.csv").write_text(
        "time,fx,fy,fz,tx,ty,tz,vx,vy,vz\n"
        + "".join(f"{t / 100},0,0,0,0,0,0,0,0,0\n" for t in range(50))
    )
    converted = CliRunner().invoke(main, ["convert", "ft.csv", "-o", "c.mcap", "--task", "gown"])
    assert converted.exit_code == 0, converted.output
    assert read_trial("c.mcap").metadata.source["file"].endswith("caf\\xe9/ft.csv")
    name = os.fsdecode(b"tr\xffial.mcap")
    Path(name).write_bytes((SAMPLES / "gown.mcap").read_bytes())
    described = CliRunner().invoke(main, ["info", name, "--json"])
    assert described.exit_code == 0 and "tr\\\\xffial.mcap" in described.output


@pytest.mark.skipif(sys.platform == "win32", reason="symbolic links need privileges there")
@pytest.mark.parametrize(
    "args",
    [
        ["convert", "{link}", "-o", "{tmp}/t.mcap", "--task", "gown"],
        ["convert", "{csv}", "--motion", "{link}", "-o", "{tmp}/t.mcap", "--task", "gown"],
        ["view", "{link}", "--save", "{tmp}/t.rrd"],
        ["infer", str(SAMPLE), "--model", "{link}", "-o", "{tmp}/t.rrd"],
        ["train", "{link}", "-o", "{tmp}/model"],
        ["eval", "{link}", "{tmp}"],
    ],
    ids=["convert", "motion", "view", "model", "train", "eval"],
)
def test_an_input_that_is_a_link_to_nothing_says_where_it_leads(
    tmp_path: Path, args: list[str]
) -> None:
    """It was "no such file" (or model or dataset folder), of a name `ls` lists."""
    (csv := tmp_path / "ft.csv").write_text("time,fx,fy,fz,tx,ty,tz\n0,0,0,0,0,0,0\n")
    (link := tmp_path / "link").symlink_to(tmp_path / "moved")
    given = [a.format(tmp=tmp_path, link=link, csv=csv) for a in args]
    result = CliRunner().invoke(main, given)
    assert result.exit_code == 1, result.output
    assert result.output == (
        f"Error: {link}: is a symbolic link to {tmp_path / 'moved'}, which does not exist; "
        "mend the link\n"
    )
    assert sorted(p.name for p in tmp_path.iterdir()) == ["ft.csv", "link"]


def test_an_output_that_is_a_link_to_nothing_is_an_existing_name(tmp_path: Path) -> None:
    """Refused up front; it used to pass, and the finished trial was dropped at the end."""
    (dangling := tmp_path / "t.mcap").symlink_to(tmp_path / "elsewhere.mcap")
    args = ["record", "--task", "gown", "--duration", "0.1", "-o", str(dangling)]
    result = CliRunner().invoke(main, args)
    assert result.exit_code == 1 and "file exists; pass --overwrite" in result.output


@pytest.mark.parametrize("command", ["record", "convert", "generate"])
def test_a_forgotten_task_is_one_line_naming_the_choices(tmp_path: Path, command: str) -> None:
    """Where click put each choice on a line of its own after a tab."""
    given = {"convert": [str(SAMPLE)], "generate": ["--trials", "2"]}.get(command, [])
    args = [command, *given, "-o", str(tmp_path / ("d" if command == "generate" else "t.mcap"))]
    result = CliRunner().invoke(main, args)
    assert result.exit_code == 2, result.output
    error = result.output.strip().splitlines()[-1]
    assert error == "Error: Missing option '--task'. Choose from: gown, shorts.", result.output


@pytest.mark.parametrize(
    ("folder", "example"), [("", "gown.mcap"), ("models", "models/gown")], ids=["trials", "models"]
)
def test_info_on_a_folder_of_trials_or_models_names_one_to_give(folder: str, example: str) -> None:
    """`dresslog info samples` or `samples/models`, a first look at the repository, where
    it had been told only that the folder is neither a model nor a dataset."""
    result = CliRunner().invoke(main, ["info", str(SAMPLES / folder)])
    assert result.exit_code == 1 and result.stderr.count("\n") == 1, result.output
    kind = "models" if folder else "trials"
    said = f"; a folder of {kind}: `dresslog info` takes one, e.g. {SAMPLES / example}\n"
    assert result.stderr.endswith(said), result.stderr
