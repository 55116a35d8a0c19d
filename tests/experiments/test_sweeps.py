"""`dresslog sweep` (dresslog.experiments.sweeps): tables, resumed and damaged sweeps, and
its bad input."""

from __future__ import annotations

import json
import re
import shutil
import warnings
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner, Result

from dresslog.cli.main import main
from dresslog.dataset import Execution, generate, load_manifest
from dresslog.errors import DatasetError, DresslogWarning
from dresslog.experiments import Scores, SweepReport, sweep, sweep_settings
from dresslog.spec import Task
from tests.conftest import SAMPLES, prints_warnings
from tests.experiments.conftest import fake_model, invoke

#: For a sweep of sequences too short to reach the arm, kept short for speed: the warning
#: that no sequence carries force is beside the point of the test.
short_sequences = pytest.mark.filterwarnings(
    "ignore:.*carries force on the limb:dresslog.errors.DresslogWarning"
)


def lines(output: str) -> list[str]:
    """`output`'s lines but the warning that no sequence carries force, which a sweep of
    0.3 s sequences (ended before the garment reaches the arm) gives."""
    return [line for line in output.splitlines() if "carries force on the limb" not in line]


@pytest.fixture(scope="module")
def swept(model: Path, tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, int, str]:
    """`dresslog sweep` of the `model` fixture without -o (into MODEL-sweep in the current
    folder), of in-range, speed:0.2 and rot:z:10, 2 sequences of 0.3 s each: its folder,
    exit code and output. Simulated once for the tests that read it; one that sweeps on
    copies it."""
    here = tmp_path_factory.mktemp("swept")
    with pytest.MonkeyPatch.context() as patch, warnings.catch_warnings():
        patch.chdir(here)
        warnings.filterwarnings("ignore", ".*carries force on the limb", DresslogWarning)
        code, output = invoke(
            "sweep", model, "--speeds", "0.2", "--rotations", "z:10", "-n", "2",
            "--duration", "0.3", "--workers", "2", "-q",
        )  # fmt: skip
    return here / f"{model.name}-sweep", code, output


@pytest.fixture(scope="module")
def sample_swept(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Result]:
    """The bundled gown model swept over in-range, speed:0.2 and rot:z:10, 1 sequence of
    0.3 s each (too short to reach the arm): its folder and `dresslog sweep`'s result, the
    warning of no force printed. Simulated once; a test that sweeps on copies the folder."""
    out = tmp_path_factory.mktemp("sample-swept") / "sweep"
    args = ["sweep", str(SAMPLES / "models" / "gown"), "--speeds", "0.2", "--rotations", "z:10"]
    with warnings.catch_warnings():
        warnings.simplefilter("default", DresslogWarning)  # printed, as in a user's shell
        result = CliRunner().invoke(
            main, [*args, "-n", "1", "--duration", "0.3", "--workers", "1", "-q", "-o", str(out)]
        )
    return out, result


def test_sweep_says_why_its_ratios_are_nan_when_no_sequence_has_force(
    sample_swept: tuple[Path, Result],
) -> None:
    """As eval: sweep's table printed nan in both ratio columns, unexplained."""
    out, result = sample_swept
    assert result.exit_code == 0, result.output
    assert result.stdout.splitlines()[1].split()[-2:] == ["nan", "nan"]  # in-range
    assert result.stderr == (
        f"Warning: {out}: no sweep sequence of in-range, speed:0.2, rot:z:10 carries force on the "
        "limb, so the all-zero RMSE is 0 and the ratio to it is not a number (nan), as is "
        "x in-range, the in-range RMSE being 0 too; sweep longer sequences (--duration)\n"
    )


@pytest.mark.slow
@short_sequences
def test_sweep_writes_a_table_and_a_plot(
    model: Path, swept: tuple[Path, int, str], tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    out, code, output = swept  # without -o: MODEL-sweep in the current folder
    monkeypatch.chdir(out.parent)
    assert code == 0, output
    assert "trained at speeds 0.1-0.15 m/s, the limb never turned\n" in output  # the card's
    assert f"wrote {model.name}-sweep: sweep.csv, sweep.json and sweep.png" in output
    assert not model.with_name(f"{model.name}-sweep").exists()
    assert "in-range" in output and "speed:0.2" in output and "rot:z:10" in output
    rows = (out / "sweep.csv").read_text().splitlines()
    assert len(rows) == 4 and rows[1].startswith("in-range,baseline")
    assert (out / "sweep.png").read_bytes()[:4] == b"\x89PNG"

    def strict(constant: str) -> None:
        raise AssertionError(f"{constant} is not JSON")

    saved = json.loads((out / "sweep.json").read_text(), parse_constant=strict)
    assert saved["settings"][0]["value"] is None  # the in-range setting has no swept value
    # the JSON carries the table's ratio to in-range, as the CSV does
    ratios = [float(row.split(",")[-1]) for row in rows[1:]]
    assert [s["ratio_to_in_range"] for s in saved["settings"]] == pytest.approx(ratios, 1e-3)
    # what the model was trained on, from its card: the `data` fixture drew its speeds
    assert (saved["trained_speeds"], saved["trained_rotations"]) == ([[0.10, 0.15]], [])
    assert saved["trained_unturned"] is True
    speeds = {e.spec.speed for e in load_manifest(out / "speed_0.2").trials}
    assert speeds == {0.2}
    # every setting re-simulates the same sequences: same seeds, same paths
    paths = [
        sorted((e.spec.seed, tuple(e.spec.control_points)) for e in load_manifest(out / f).trials)
        for f in ("in-range", "speed_0.2", "rot_z_10")
    ]
    assert paths[0] == paths[1] == paths[2] and len(paths[0]) == 2
    code, output = invoke("sweep", model, "--speeds", "0.2", "-n", "1", "--duration", "0.3")
    assert code == 1 and "has 2 sweep trials, more than the 1 asked for (-n sets it)" in output
    before = (out / "in-range" / "manifest.json").read_bytes()
    code, output = invoke(
        "generate", "--task", "gown", "--trials", "2", "-o", out / "in-range", "--duration", "0.3"
    )
    assert code == 1 and "holds 2 sweep trials, made by `dresslog sweep`" in output
    assert (out / "in-range" / "manifest.json").read_bytes() == before
    for command in (("eval", model, out), ("train", out, "-o", tmp_path / "m")):
        code, output = invoke(*command)  # the sweep's own folder, not one of its settings'
        assert code == 1 and "a sweep's folder: `dresslog sweep` scores its settings" in output


@pytest.mark.slow
@prints_warnings
def test_a_sweep_of_longer_sequences_than_the_training_says_so(model: Path, tmp_path: Path) -> None:
    """Sequences longer than the training's passed silently, as if the model's error on
    them were its fit: the sweep now warns before simulating and its line and plot say it."""
    out = tmp_path / "sweep"
    args = ["sweep", str(model), "--speeds", "0.2", "-n", "1", "--duration", "2"]
    result = CliRunner().invoke(main, [*args, "--workers", "1", "-q", "-o", str(out)])
    assert result.exit_code == 0, result.output
    assert result.stderr.startswith(
        "Warning: sweep sequences of 2 s run longer than the model's training trials "
        "(1.5 s), so every setting's error"
    )
    trained = "trained at speeds 0.1-0.15 m/s, the limb never turned, on 1.5 s trials (these 2 s)"
    assert f"{trained}\n" in result.stdout
    saved = json.loads((out / "sweep.json").read_text())
    assert (saved["duration"], saved["trained_duration"]) == (2, 1.5)
    result = CliRunner().invoke(
        main,
        [
            "sweep",
            str(model),
            "--speeds",
            "0.2",
            "-n",
            "1",
            "--duration",
            "1",
            "-q",
            "-o",
            str(tmp_path / "short"),
        ],
    )
    assert result.exit_code == 0 and "trials (these" not in result.output  # a prefix
    # no --duration: the spec's 7 s, longer than this model's 1.5 s, is warned of too
    args = ["sweep", str(model), "--speeds", "0.2", "-n", "1", "--workers", "2", "-q"]
    result = CliRunner().invoke(main, [*args, "-o", str(tmp_path / "default")])
    assert result.exit_code == 0, result.output
    assert result.stderr.startswith("Warning: sweep sequences of 7 s run longer than the model's")
    assert "on 1.5 s trials (these 7 s)\n" in result.stdout


@pytest.mark.slow
@prints_warnings
def test_a_sweep_run_again_with_other_values_tables_every_complete_setting(
    model: Path, swept: tuple[Path, int, str], tmp_path: Path
) -> None:
    """The table, JSON and plot held only the settings of the last run, the others'
    folders left on disk unsaid."""
    out = tmp_path / "sweep"
    shutil.copytree(swept[0], out)  # a first run: speed 0.2, rotation z:10, 2 of 0.3 s
    assert swept[1] == 0, swept[2]
    common = ["--duration", "0.3", "--workers", "2", "-q", "-o", out]
    code, output = invoke("sweep", model, "--speeds", "0.15", "-n", "2", *common)
    assert code == 0 and "Warning" not in "".join(lines(output)), output
    names = ["in-range", "speed:0.15", "speed:0.2", "rot:z:10"]
    assert [row.split()[0] for row in lines(output)[1:5]] == names
    rows = (out / "sweep.csv").read_text().splitlines()[1:]
    assert [row.split(",")[0] for row in rows] == names
    saved = json.loads((out / "sweep.json").read_text())
    assert [s["name"] for s in saved["settings"]] == names
    # of other sequences (-n 3 extends in-range): not comparable, left out and named
    code, output = invoke("sweep", model, "--speeds", "0.25", "-n", "3", *common)
    assert code == 0, output
    rows = (out / "sweep.csv").read_text().splitlines()[1:]
    assert [row.split(",")[0] for row in rows] == ["in-range", "speed:0.25"]
    warning = [line for line in lines(output) if line.startswith("Warning: ")]
    assert len(warning) == 1, output
    assert "speed:0.15 (2/2 sweep), speed:0.2 (2/2 sweep), rot:z:10 (2/2 sweep);" in warning[0]


@pytest.mark.slow
@prints_warnings
def test_a_damaged_earlier_sweep_setting_is_left_out_and_named_not_fatal(
    sample_swept: tuple[Path, Result], tmp_path: Path
) -> None:
    """A corrupt trial in an earlier run's setting stopped the new sweep with "run `dresslog
    generate` on the folder again" (which refuses a sweep's folder), and a missing one was
    called "not 1 complete sequences" beside "(1/1 sweep)"."""
    model, out = SAMPLES / "models" / "gown", tmp_path / "sweep"
    shutil.copytree(sample_swept[0], out)  # a first run: speed 0.2, rotation z:10
    common = ["-n", "1", "--duration", "0.3", "--workers", "1", "-q", "-o", out]
    code, output = invoke("sweep", model, "--speeds", "0.25", *common)  # an intact one
    assert code == 0, output
    trial = out / "speed_0.2" / "sweep" / "000000.mcap"
    data = bytearray(trial.read_bytes())
    middle = len(data) // 2
    data[middle : middle + 400] = bytes(400)  # the same size: only its checksum tells
    trial.write_bytes(bytes(data))
    (out / "rot_z_10" / "sweep" / "000000.mcap").unlink()
    for folder in ("speed_0.2", "rot_z_10"):
        shutil.rmtree(out / folder / ".cache", ignore_errors=True)
    code, output = invoke("sweep", model, "--speeds", "0.15", *common)
    assert code == 0, output
    rows = (out / "sweep.csv").read_text().splitlines()[1:]
    assert [row.split(",")[0] for row in rows] == ["in-range", "speed:0.15", "speed:0.25"]
    warning = [line for line in lines(output) if line.startswith("Warning: ")]
    assert warning == [
        f"Warning: {out}: left out of the table, as damaged: "
        "speed:0.2 (a trial is damaged or missing; sweep it again with --speeds 0.2), "
        "rot:z:10 (a trial is damaged or missing; sweep it again with --rotations z:10)"
    ], output
    code, output = invoke("sweep", model, "--speeds", "0.2", "--rotations", "z:10", *common)
    assert code == 0 and "Warning" not in "".join(lines(output)), output  # the cure it names works
    rows = (out / "sweep.csv").read_text().splitlines()[1:]
    assert len(rows) == 5, rows


@pytest.mark.slow
@short_sequences
def test_the_sweep_table_lists_settings_by_kind_axis_and_value_as_the_plot_does(
    sample_swept: tuple[Path, Result], tmp_path: Path
) -> None:
    """Rows came in the order asked, this run's before earlier runs': 0.25, 0.15, 0.2."""
    model, out = SAMPLES / "models" / "gown", tmp_path / "sweep"
    shutil.copytree(sample_swept[0], out)  # a first run: speed 0.2, rotation z:10
    common = ["-n", "1", "--duration", "0.3", "--workers", "1", "-q", "-o", out]
    code, output = invoke("sweep", model, "--speeds", "0.25,0.15", "--rotations", "y:-5", *common)
    assert code == 0, output
    names = ["in-range", "speed:0.15", "speed:0.2", "speed:0.25", "rot:y:-5", "rot:z:10"]
    assert [row.split()[0] for row in lines(output)[1:7]] == names, output
    rows = (out / "sweep.csv").read_text().splitlines()[1:]
    assert [row.split(",")[0] for row in rows] == names
    saved = json.loads((out / "sweep.json").read_text())
    assert [s["name"] for s in saved["settings"]] == names


@short_sequences
def test_sweep_never_writes_into_a_dataset_or_a_model_folder(
    model: Path, data: Path, tmp_path: Path
) -> None:
    for folder, out in ((data, data), (model, model), (data, data / "train" / "sweep")):
        before = sorted(folder.rglob("*"))
        code, output = invoke("sweep", model, "--speeds", "0.2", "-n", "1", "-o", out)
        assert code == 1 and "give the sweep a folder of its own" in output
        assert sorted(folder.rglob("*")) == before
    (web := tmp_path / "webapp").mkdir()  # another tool's manifest.json is no dataset
    (web / "manifest.json").write_text('{"name": "webapp", "version": "1.0"}')
    args = ["-n", "1", "--duration", "0.2", "--workers", "1", "-q", "-o", web / "sweep"]
    code, output = invoke("sweep", model, "--speeds", "0.2", *args)
    assert code == 0, output


def test_a_sweep_value_given_twice_is_one_setting() -> None:
    settings = sweep_settings(Task.GOWN, ["0.2", "0.20", "0.25"], ["z:-0", "z:0", "z:0.0"])
    assert [s.name for s in settings] == ["in-range", "speed:0.2", "speed:0.25", "rot:z:0"]
    # two values %g would print alike are two settings (the second was dropped)
    close = sweep_settings(Task.GOWN, ["0.1234567", "0.1234568"], [])
    assert [s.name for s in close[1:]] == ["speed:0.1234567", "speed:0.1234568"]
    # a script's float32 speeds name the folders a command-line sweep made
    single = sweep_settings(Task.GOWN, list(np.array([0.2, 0.25], np.float32)), [])
    assert [s.name for s in single[1:]] == ["speed:0.2", "speed:0.25"]


def test_a_sweep_called_from_a_script_says_what_is_wrong_with_its_arguments(
    model: Path, tmp_path: Path
) -> None:
    """A zero duration was dropped (every trial ran 7 s), a str swept letter by letter,
    and an output that is a file was a FileExistsError traceback."""

    wrong = [
        ({"speeds": [0.2], "duration": 0}, "in-range: invalid duration"),
        ({"speeds": "0.2"}, "speeds must be a list of values, not the one '0.2'"),
        ({"speeds": 0.2}, "speeds must be a list of values"),
        ({"rotations": "z:15"}, "rotations must be a list of values"),
    ]
    for arguments, message in wrong:
        with pytest.raises(DatasetError, match=re.escape(message)):
            sweep(model, tmp_path / "s", n=1, **arguments)
        assert not (tmp_path / "s").exists()
    (taken := tmp_path / "taken").write_text("mine")
    with pytest.raises(DatasetError, match="is a file; give the sweep a folder of its own"):
        sweep(model, taken, speeds=[0.2], n=1)
    assert taken.read_text() == "mine"
    (dangling := tmp_path / "gone").symlink_to("nowhere")
    with pytest.raises(DatasetError, match="is a symbolic link to nothing"):
        sweep(model, dangling, speeds=[0.2], n=1)


@pytest.mark.parametrize(
    ("option", "value", "message", "usage"),
    [
        ("rotations", "z:10,z:999", "rot:z:999: invalid limb_rotation.degrees", True),
        ("speeds", "0.2,-1", "speed:-1: invalid speed", True),
        ("rotations", "z:10,y:88", "rot:y:88: the fist lies inside the rest of the arm", False),
    ],
)
def test_sweep_rejects_a_bad_setting_before_making_its_folder(
    model: Path, tmp_path: Path, option: str, value: str, message: str, usage: bool
) -> None:
    """The library refuses for its callers; `dresslog sweep` refuses a value out of the spec's
    range first, as a usage error, and reports the library's refusal of what only it knows
    (the limb's geometry)."""

    out = tmp_path / "sweep"
    with pytest.raises(DatasetError, match=re.escape(message)):
        sweep(model, out, n=1, **{option: value.split(",")})
    assert not out.exists()
    code, output = invoke("sweep", model, f"--{option}", value, "-o", out)
    if usage:
        assert code == 2 and f"Invalid value for '--{option}'" in output, output
    else:
        assert code == 1 and message in output, output
    assert not out.exists()


@pytest.mark.slow
def test_a_model_of_one_simulator_is_swept_and_scored_on_its_own(tmp_path: Path) -> None:
    """A model trained on trials of simulator v8 reads such trials only: its sweep
    simulates them so, and `eval` names another version's."""
    near = {"duration": 0.5, "limb_offset": [0.30, 0.0, 0.05]}
    balanced = tmp_path / "balanced"
    generate("gown", 3, balanced, execution=Execution(workers=2), test_fraction=1 / 3,
             overrides={**near, "sim": {"simulator": 8, "wrench_from": "momentum"}})  # fmt: skip
    model = tmp_path / "model"
    code, output = invoke("train", balanced, "-o", model, "--epochs", "1", "--hidden", "4",
                          "--layers", "1", "-q")  # fmt: skip
    assert code == 0, output
    with pytest.warns(DresslogWarning, match="no sweep sequence"):  # 0.5 s reach no limb
        report = sweep(model, tmp_path / "sweep", speeds=[0.12], n=1, duration=0.5,
                       progress=False)  # fmt: skip
    assert [s.name for s in report.settings] == ["in-range", "speed:0.12"]
    for setting in report.settings:
        manifest = load_manifest(tmp_path / "sweep" / setting.folder)
        assert manifest.overrides["sim"] == {"simulator": 8, "wrench_from": "momentum"}
    current = tmp_path / "v9"
    generate("gown", 1, current, execution=Execution(workers=1), test_fraction=1, overrides=near)
    code, output = invoke("eval", model, current)
    assert code == 0, output
    assert "simulator v9 (trained on v8)" in output


@pytest.mark.parametrize("name", ["x.mcap", "x.rrd", "X.MCAP", "x.bag"])
@pytest.mark.parametrize("command", ["generate", "sweep"])
def test_generate_and_sweep_refuse_a_folder_named_as_a_recording(
    tmp_path: Path, command: str, name: str
) -> None:
    """As `train` does: `generate -o data/x.mcap` and `sweep -o runs/x.rrd` made folders
    that every tool opening a file by its name then took for a trial or a recording."""
    model = fake_model(tmp_path / "gown", "gown")
    before = sorted(tmp_path.rglob("*"))
    out = tmp_path / "runs" / name
    what, args = {
        "generate": ("a dataset", ["generate", "--task", "gown", "--trials", "2"]),
        "sweep": ("a sweep", ["sweep", model, "--speeds", "0.2", "-n", "1"]),
    }[command]
    code, output = invoke(*args, "-o", out, "-q")
    stem, suffix = Path(name).stem, Path(name).suffix
    assert code == 1 and output == (
        f"Error: {out}: {what} is a folder, not a {suffix.lower()} recording; name it "
        f"without {suffix} (e.g. {tmp_path / 'runs' / stem})\n"
    ), output
    assert sorted(tmp_path.rglob("*")) == before  # no folder made


def test_the_sweep_table_csv_and_json_give_each_settings_ratio_to_all_zero(
    tmp_path: Path,
) -> None:
    """The README's sweep tables read the RMSE over all-zero per setting; the sweep's own
    table and CSV gave only the ratio to in-range."""
    from dresslog.experiments import sweeps

    settings = sweep_settings(Task.GOWN, [0.2], [])
    scores = [
        Scores(8, 0.01, 0.02, 0.5, 0.8, 0.6, 0.3, 0.4),
        Scores(8, 0.03, 0.04, 0.75, *[0.5] * 4),
    ]
    report = SweepReport(
        "gown", "m", 8, 0.01, [replace(s, scores=c) for s, c in zip(settings, scores, strict=True)]
    )
    table = report.table().splitlines()
    assert table[0].endswith("RMSE (N)    zero (N)   ratio  x in-range"), table[0]
    assert table[2].split() == ["speed:0.2", "8", "0.03000", "0.04000", "0.750", "3.00"]
    sweeps._write_sweep(tmp_path, report)
    rows = (tmp_path / "sweep.csv").read_text().splitlines()
    assert rows[0] == "setting,kind,axis,value,n,rmse,zero_rmse,ratio,ratio_to_in_range"
    assert rows[2] == "speed:0.2,speed,,0.2,8,0.03,0.04,0.75,3"
    saved = json.loads((tmp_path / "sweep.json").read_text())["settings"]  # keys as before
    assert [(s["scores"]["ratio"], s["ratio_to_in_range"]) for s in saved] == [(0.5, 1), (0.75, 3)]


def test_a_sweep_stopped_while_writing_leaves_the_last_table_and_plot_together(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    from dresslog.experiments import sweeps

    def report(speed: float) -> SweepReport:
        settings = sweep_settings(Task.GOWN, [speed], [])
        scores = Scores(8, 0.01, 0.02, 0.5, 0.8, 0.6, 0.3, 0.4)
        return SweepReport("gown", "m", 8, 0.01, [replace(s, scores=scores) for s in settings])

    sweeps._write_sweep(tmp_path, report(0.2))
    before = {p.name: p.read_bytes() for p in tmp_path.iterdir()}
    assert sorted(before) == ["sweep.csv", "sweep.json", "sweep.png"]

    def stopped(path: Path, report: SweepReport) -> None:  # matplotlib's import takes a second
        raise KeyboardInterrupt

    monkeypatch.setattr(sweeps, "plot_sweep", stopped)
    with pytest.raises(KeyboardInterrupt):
        sweeps._write_sweep(tmp_path, report(0.25))
    assert {p.name: p.read_bytes() for p in tmp_path.iterdir()} == before


@pytest.mark.parametrize(
    ("options", "code", "message"),
    [
        ([], 2, "Error: give --speeds, --rotations or both"),
        # malformed values are usage errors, as record's --rotation q 5 is; they were exit 1
        (["--speeds", "0.2,fast"], 2, "Invalid value for '--speeds': speed 'fast' is not a"),
        (["--rotations", "q:5"], 2, "Invalid value for '--rotations': rotation 'q:5' is not"),
        # a script's `--speeds "$SPEEDS"` of an empty variable: it was told to give --speeds
        (["--speeds", ""], 2, "Error: --speeds is empty; give --speeds, --rotations or both"),
        (["--rotations", " , "], 2, "Error: --rotations is empty; give --speeds, --rotations"),
    ],
)  # fmt: skip
def test_sweep_without_a_setting_or_with_a_bad_speed_is_refused(
    model: Path, tmp_path: Path, options: list[str], code: int, message: str
) -> None:
    exit_code, output = invoke("sweep", model, *options, "-o", tmp_path / "s")
    assert exit_code == code and message in output, output
    assert not (tmp_path / "s").exists()
