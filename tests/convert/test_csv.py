"""`dresslog convert` on force/torque CSV exports in common layouts, and the resampling maths."""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from dresslog.cli.main import main
from dresslog.convert import ConversionWarning, convert, csv_lines
from dresslog.convert import resample as rs
from dresslog.convert.csv import role_of
from dresslog.convert.units import value_scale
from dresslog.errors import ConversionError
from dresslog.io.reader import TrialReader, read_trial
from dresslog.io.summary import format_summary, summarize
from tests.conftest import SAMPLES, prints_warnings
from tests.convert.signals import T0_NS, pose, seconds_of, times, twist, wrench


def write_csv(path: Path, header: list[str], columns: list[np.ndarray]) -> Path:
    rows = np.column_stack(columns).astype(object)
    lines = [",".join(header)] + [",".join(str(v) for v in row) for row in rows]
    path.write_text("\n".join(lines) + "\n")
    return path


def ati_style(tmp_path: Path) -> Path:
    """One file, relative seconds, units in brackets, velocity beside the wrench (1 kHz)."""
    t_ns = times(1000, 2.0)
    t = seconds_of(t_ns)
    header = ["Time (s)", "Fx (N)", "Fy (N)", "Fz (N)", "Mx (Nm)", "My (Nm)", "Mz (Nm)",
              "vx (m/s)", "vy (m/s)", "vz (m/s)", "status"]  # fmt: skip
    columns = [np.round(t, 6), *wrench(t).T, *twist(t)[:, :3].T, np.zeros(len(t))]
    return write_csv(tmp_path / "ati.csv", header, columns)


def rostopic_style(tmp_path: Path) -> tuple[Path, Path]:
    """rostopic echo -p exports: absolute ns, `%time` and `field.header.stamp`, pose file apart."""
    tw, tp = times(1000, 2.0), times(50, 2.0, 0.003)
    head = ["%time", "field.header.seq", "field.header.stamp", "field.header.frame_id"]
    wrench_header = head + [f"field.wrench.{q}.{a}" for q in ("force", "torque") for a in "xyz"]
    frame = np.full(len(tw), "ft")
    wrench_file = write_csv(
        tmp_path / "wrench.csv",
        wrench_header,
        [tw + 700_000, np.arange(len(tw)), tw, frame, *wrench(seconds_of(tw)).T],
    )
    pose_header = head + [f"field.pose.position.{a}" for a in "xyz"]
    pose_header += [f"field.pose.orientation.{a}" for a in "xyzw"]
    pose_file = write_csv(
        tmp_path / "pose.csv",
        pose_header,
        [tp + 900_000, np.arange(len(tp)), tp, np.full(len(tp), "base"), *pose(seconds_of(tp)).T],
    )
    return wrench_file, pose_file


def converted(out: Path, start_ns: int, relative: bool = False):
    with TrialReader(out) as reader:
        t = (reader.wrench.t_ns + start_ns) / 1e9 if relative else None
        t = seconds_of(reader.wrench.t_ns + start_ns) if t is None else t
        return t, reader.wrench.values, reader.twist.values, reader.pose


def test_an_ati_style_csv_with_velocity_columns(tmp_path: Path) -> None:
    report = convert(ati_style(tmp_path), tmp_path / "t.mcap", "gown")
    t, got_wrench, got_twist, got_pose = converted(
        tmp_path / "t.mcap", report.source["start_ns"], True
    )
    np.testing.assert_allclose(got_wrench, wrench(t, vibration=False), atol=5e-4)
    np.testing.assert_allclose(got_twist[:, :3], twist(t)[:, :3], atol=1e-4)
    assert got_pose is None
    assert any("read as s" in n for n in report.source["notes"])
    assert any("ignored columns status" in n for n in report.source["notes"])


def test_rostopic_exports_with_a_motion_file(tmp_path: Path) -> None:
    wrench_file, pose_file = rostopic_style(tmp_path)
    report = convert(wrench_file, tmp_path / "t.mcap", "shorts", motion=pose_file)
    t, got_wrench, got_twist, got_pose = converted(tmp_path / "t.mcap", report.source["start_ns"])
    assert report.source["start_ns"] > T0_NS  # absolute header stamps, in ns
    np.testing.assert_allclose(got_wrench, wrench(t, vibration=False), atol=5e-4)
    np.testing.assert_allclose(got_twist, twist(t), atol=2e-4)
    np.testing.assert_allclose(got_pose.values, pose(t), atol=1e-4)


def test_load_takes_paths_as_text_too(tmp_path: Path) -> None:
    """A script passes `"ft.csv"`, as the Python API's other path arguments take it."""
    from dresslog.convert import load

    wrench_file, pose_file = rostopic_style(tmp_path)
    source = load(str(wrench_file), motion=str(pose_file))
    assert source.path == wrench_file and source.pose is not None
    with pytest.raises(ConversionError, match="no such file or folder"):
        load(str(tmp_path / "missing.csv"))


def test_an_unknown_task_is_named_with_the_two_there_are(tmp_path: Path) -> None:
    with pytest.raises(ConversionError, match="task 'hat' is not one of gown, shorts"):
        convert(ati_style(tmp_path), tmp_path / "t.mcap", "hat")
    assert not (tmp_path / "t.mcap").exists()


@pytest.mark.parametrize(
    ("seconds", "nanoseconds"),
    [("header.stamp.secs", "header.stamp.nsecs"), ("header.stamp.sec", "header.stamp.nanosec")],
)
def test_a_stamp_split_into_seconds_and_nanoseconds_is_joined(
    tmp_path: Path, seconds: str, nanoseconds: str
) -> None:
    """bagpy (ROS 1) and ROS 2 exports: whole seconds and nanoseconds in two columns."""
    t_ns = times(1000, 2.0)
    header = ["Time", "header.seq", seconds, nanoseconds, "header.frame_id"]
    header += [f"wrench.{q}.{a}" for q in ("force", "torque") for a in "xyz"]
    header += [f"pose.position.{a}" for a in "xyz"]
    t = seconds_of(t_ns)
    columns = [t_ns / 1e9 + 0.0007, np.arange(len(t)), t_ns // 10**9, t_ns % 10**9]
    columns += [np.full(len(t), "ft"), *wrench(t).T, *pose(t)[:, :3].T]
    report = convert(
        write_csv(tmp_path / "bagpy.csv", header, columns), tmp_path / "t.mcap", "gown"
    )
    got_t, got_wrench, *_ = converted(tmp_path / "t.mcap", report.source["start_ns"])
    np.testing.assert_allclose(got_wrench, wrench(got_t, vibration=False), atol=5e-4)
    assert f"read as s + {nanoseconds!r} in ns" in report.source["notes"][0]


def test_a_time_unit_guessed_wrong_is_refused_with_the_option_to_give_it(tmp_path: Path) -> None:
    t_ms = np.arange(2000) * 1.0  # 1 kHz in milliseconds, the header silent on the unit
    t = t_ms / 1000
    header = ["time", "fx", "fy", "fz", "tx", "ty", "tz", "x", "y", "z"]
    path = write_csv(tmp_path / "ms.csv", header, [t_ms, *wrench(t).T, *pose(t)[:, :3].T])
    out = tmp_path / "t.mcap"
    with pytest.raises(ConversionError, match=r"1 s apart \(1 Hz\).*--time-unit ms"):
        convert(path, out, "gown")
    assert not out.exists()
    report = convert(path, out, "gown", time_unit="ms")
    assert report.steps == 199  # 2 s at 100 Hz, less the half bins the averaging needs


def test_a_time_unit_the_header_gets_wrong_is_refused_as_a_guessed_one_is(tmp_path: Path) -> None:
    """`Time (s)` over milliseconds made a 33-minute trial of interpolation with exit 0,
    where the same numbers under `time` were refused; --time-unit overrides the header."""
    t = np.arange(1000) / 500.0  # 2 s at 500 Hz, written in ms
    names = ["Time (s)", "Fx (N)", "Fy (N)", "Fz (N)", "Mx (Nm)", "My (Nm)", "Mz (Nm)"]
    path = write_csv(tmp_path / "ms.csv", [*names, "vx", "vy", "vz"],
                     [t * 1000, *wrench(t).T, *twist(t)[:, :3].T])  # fmt: skip
    out = tmp_path / "t.mcap"
    args = ["convert", str(path), "-o", str(out), "--task", "gown"]
    refused = CliRunner().invoke(main, args)
    assert refused.exit_code == 1
    assert refused.output == (
        f"Error: {path}: time column 'Time (s)' read as s, as its header says, gives samples "
        "2 s apart (0.5 Hz), no sensor's rate; if the header is wrong, give the unit with "
        "--time-unit ms|us|s|ns\n"
    )
    assert not out.exists()
    given = CliRunner().invoke(main, [*args, "--time-unit", "ms"])
    assert given.exit_code == 0 and "Warning" not in given.output, given.output
    assert read_trial(out).wrench.t_ns[-1] < 2e9


def test_units_in_the_header_are_scaled_to_si_and_unknown_ones_refused(tmp_path: Path) -> None:
    """A sensor exporting kN, N-mm and mm/s gives the trial of one exporting N, N m, m/s."""
    t_ns = times(1000, 2.0)
    t = seconds_of(t_ns)
    w, v = wrench(t), twist(t)[:, :3]
    si = write_csv(tmp_path / "si.csv", ["Time (s)", *HEADER_SI], [np.round(t, 6), *w.T, *v.T])
    milli = [np.round(t, 6), *(w[:, :3] / 1e3).T, *(w[:, 3:] * 1e3).T, *(v * 1e3).T]
    other = write_csv(tmp_path / "milli.csv", ["Time (s)", *HEADER_MILLI], milli)
    convert(si, tmp_path / "si.mcap", "gown")
    report = convert(other, tmp_path / "milli.mcap", "gown")
    assert any("scaled to SI units: 'Fx [sensor 1] (kN)'" in n for n in report.source["notes"])
    _, si_wrench, si_twist, _ = converted(tmp_path / "si.mcap", 0)
    _, milli_wrench, milli_twist, _ = converted(tmp_path / "milli.mcap", 0)
    np.testing.assert_allclose(milli_wrench, si_wrench, rtol=1e-6, atol=1e-9)
    np.testing.assert_allclose(milli_twist, si_twist, rtol=1e-6, atol=1e-9)
    feet = ["Time (s)", *HEADER_SI[:6], "vx (ft/s)", *HEADER_SI[7:]]
    path = write_csv(tmp_path / "ft.csv", feet, [np.round(t, 6), *w.T, *v.T])
    with pytest.raises(ConversionError, match=r"'vx \(ft/s\)' is in 'ft/s'.*one of m/s"):
        convert(path, tmp_path / "ft.mcap", "gown")
    assert not (tmp_path / "ft.mcap").exists()


HEADER_SI = ["Fx (N)", "Fy (N)", "Fz (N)", "Tx (N·m)", "Ty (N m)", "Tz (Nm)",
             "vx (m/s)", "vy (m/s)", "vz (m/s)"]  # fmt: skip
HEADER_MILLI = ["Fx [sensor 1] (kN)", "Fy [kN]", "Fz (kN)", "Tx (N-mm)", "Ty (N.mm)", "Tz [Nmm]",
                "vx (mm/s)", "vy (mm/s)", "vz [mm/s]"]  # fmt: skip


@pytest.mark.parametrize(
    ("header", "unit"),
    [("Fx (tool)", None), ("Fx [sensor 2]", None), ("Fx (-)", None), ("Fx (N)", "N"),
     ("Fz (hips)", None), ("Fx (ships)", None), ("Fx (N) [raw]", "N"),
     ("Fx [sensor 1] (kN)", "kN"), ("Tx (lbf-in)", "lbf-in"), ("wx (°/s)", "°/s")],
)  # fmt: skip
def test_a_bracket_is_a_unit_only_when_it_reads_as_one(header: str, unit: str | None) -> None:
    role = role_of(header)
    assert role is not None
    found = value_scale(header, role, Path("x.csv"))
    assert (found[0] if found else None) == unit


@pytest.mark.parametrize(
    ("header", "factor"),
    [("vx (mm s-1)", 1e-3), ("vx [mm·s⁻¹]", 1e-3), ("wx (degree/s)", np.pi / 180),
     ("wx (dps)", np.pi / 180), ("Tx (in-lb)", 0.1129848290276167), ("Tx (NM)", 1.0),
     ("Fx (mN)", 1e-3), ("vx (mm/second)", 1e-3), ("wx (degrees per second)", np.pi / 180),
     ("Tx (N⋅mm)", 1e-3), ("Fx (kilonewtons)", 1e3), ("Fy (newtons)", 1.0)],
)  # fmt: skip
def test_units_written_the_other_usual_ways_are_scaled_alike(header: str, factor: float) -> None:
    role = role_of(header)
    assert role is not None
    found = value_scale(header, role, Path("x.csv"))
    assert found is not None and found[1] == pytest.approx(factor)


@pytest.mark.parametrize(
    ("header", "outcome"),
    [("Time (UTC) [ms]", "ms"), ("Time [sensor] (ms)", "ms"), ("Time (msec.)", "ms"),
     ("Time (milliseconds)", "ms"), ("Time (min)", "refused"), ("Time (minutes)", "refused"),
     ("Time (cs)", "refused")],
)  # fmt: skip
def test_a_time_unit_in_any_bracket_is_read_and_one_not_read_is_refused(
    tmp_path: Path, header: str, outcome: str
) -> None:
    t = np.arange(2000) / 1000.0  # 2 s at 1 kHz, written in ms
    path = _with_velocity(tmp_path / "t.csv", t)
    lines = path.read_text().splitlines()
    rows = [f"{float(r.split(',', 1)[0]) * 1000:g},{r.split(',', 1)[1]}" for r in lines[1:]]
    path.write_text("\n".join([header + lines[0][len("time") :], *rows]) + "\n")
    if outcome == "refused":
        with pytest.raises(ConversionError, match="a unit dresslog does not read"):
            convert(path, tmp_path / "t.mcap", "gown")
    else:
        assert convert(path, tmp_path / "t.mcap", "gown").steps > 150


@pytest.mark.parametrize(
    "header",
    ["vx (km/h)", "Fx (dN)", "Fz [daN]", "Tx (kgf cm)", "wx (rev/s)", "Fx (MN)", "Fx (dyn)",
     "Fy (kip)", "vx (ips)", "Tx (kip-ft)", "Tx (dyn cm)", "Tx (ft-pdl)", "Fx (V)", "Fz (mV)",
     "Fy (pounds)"],
)  # fmt: skip
def test_a_prefixed_unit_not_converted_is_refused_not_read_as_si(header: str) -> None:
    """`km/h` read as m/s would be 3.6x wrong, silently: a unit, though not one converted."""
    role = role_of(header)
    assert role is not None
    with pytest.raises(ConversionError, match="a unit dresslog does not convert"):
        value_scale(header, role, Path("x.csv"))


@pytest.mark.parametrize("bracket", ["raw", "counts", "ADC", "raw counts"])
def test_raw_readings_without_counts_per_unit_are_refused(tmp_path: Path, bracket: str) -> None:
    """`Fx (raw)` is no label: read as newtons, a sensor's counts would be silently wrong."""
    path = _with_velocity(tmp_path / "raw.csv", np.arange(500) / 1000.0)
    lines = path.read_text().splitlines()
    header = lines[0].replace("fx", f"fx ({bracket})")
    path.write_text("\n".join([header, *lines[1:]]) + "\n")
    with pytest.raises(ConversionError, match=rf"'fx \({bracket}\)' holds '{bracket}' readings"):
        convert(path, tmp_path / "t.mcap", "gown")
    assert not (tmp_path / "t.mcap").exists()
    path.write_text("\n".join([lines[0].replace("fx", f"fx (N) [{bracket}]"), *lines[1:]]) + "\n")
    assert convert(path, tmp_path / "t.mcap", "gown").steps > 40  # unfiltered, in newtons


def test_unknown_columns_are_refused_until_mapped(tmp_path: Path) -> None:
    t = np.arange(200) / 1000.0
    values = wrench(t)
    header = ["zeit", "kx", "ky", "kz", "mx", "my", "mz", "vx", "vy", "vz"]
    path = write_csv(tmp_path / "odd.csv", header, [t, *values.T, *twist(t)[:, :3].T])
    out = tmp_path / "t.mcap"
    with pytest.raises(ConversionError, match=r"no column recognised as time.*--column time="):
        convert(path, out, "gown")
    with pytest.raises(ConversionError, match=r"no column recognised as fx.*--column fx="):
        convert(path, out, "gown", columns={"time": "zeit"})
    assert not out.exists()
    mapping = {"time": "zeit", "fx": "kx", "fy": "ky", "fz": "kz"}
    result = CliRunner().invoke(
        main,
        ["convert", str(path), "-o", str(out), "--task", "gown"]
        + [arg for role, name in mapping.items() for arg in ("--column", f"{role}={name}")],
    )
    assert result.exit_code == 0, result.output
    with pytest.raises(ConversionError, match="no such column"):
        convert(path, tmp_path / "u.mcap", "gown", columns={"fx": "nope"})


def test_a_mistyped_column_names_the_columns_of_each_file(tmp_path: Path) -> None:
    """`--column fx=Fx` for the header `Fx (N)`: the headers to pick from are said, where
    the error had said only that there is no such column."""
    robot, out = SAMPLES / "robot", tmp_path / "t.mcap"
    args = ["convert", str(robot / "ft.csv"), "--motion", str(robot / "pose.csv"), "-o"]
    result = CliRunner().invoke(main, [*args, str(out), "--task", "gown", "--column", "fx=Fx"])
    assert result.exit_code == 1 and not out.exists()
    assert result.output == (
        f"Error: {robot / 'ft.csv'}: --column fx=Fx: no such column (columns of ft.csv: "
        "time (s), Fx (N), Fy (N), Fz (N), Tx (N m), Ty (N m), Tz (N m); pose.csv: time (s), "
        "x (m), y (m), z (m), qx, qy, qz, qw)\n"
    )


def test_a_wrench_csv_without_motion_is_refused(tmp_path: Path) -> None:
    t = np.arange(100) / 1000.0
    path = write_csv(
        tmp_path / "w.csv", ["t", "fx", "fy", "fz", "tx", "ty", "tz"], [t, *wrench(t).T]
    )
    with pytest.raises(ConversionError, match="--motion FILE"):
        convert(path, tmp_path / "t.mcap", "gown")


@pytest.mark.parametrize(("folder", "problem"), [(False, "no such file"), (True, "is a folder")])
def test_a_motion_file_not_there_is_named_as_the_log_is(
    tmp_path: Path, folder: bool, problem: str
) -> None:
    """`--motion` naming no file was told `cannot read CSV: [Errno 2] No such file or
    directory: 'pose.csv'`, its name twice and Python's errno between."""
    forces = ati_style(tmp_path)
    motion = tmp_path / "pose.csv"
    if folder:
        motion.mkdir()
    result = CliRunner().invoke(
        main, ["convert", str(forces), "--motion", str(motion), "-o", str(tmp_path / "t.mcap"),
               "--task", "gown"],
    )  # fmt: skip
    assert result.exit_code == 1
    assert result.output == f"Error: {motion}: {problem}; --motion takes a CSV file\n"
    assert not (tmp_path / "t.mcap").exists()


@pytest.mark.parametrize(
    ("fault", "message"),
    [
        ("backwards", "samples 10 and 50 of 100 share the stamp 10000000 ns (time column clock)"),
        ("nan", "nan wrench force z at sample 30 (0.030 s in); drop or fill that sample"),
        ("1e39", "1e+39 wrench force z at sample 30 (0.030 s in)"),  # past float32: infinite
    ],
)
def test_a_csv_with_times_going_backwards_or_a_nan_is_refused_in_one_line(
    tmp_path: Path, fault: str, message: str
) -> None:
    t = np.arange(100) / 1000.0
    forces = wrench(t)
    if fault == "backwards":
        t[50] = t[10]
    else:
        forces[30, 2] = float(fault)
    header = ["time", "fx", "fy", "fz", "tx", "ty", "tz", "x", "y", "z"]
    path = write_csv(tmp_path / "w.csv", header, [t, *forces.T, *pose(t)[:, :3].T])
    out = tmp_path / "t.mcap"
    result = CliRunner().invoke(main, ["convert", str(path), "-o", str(out), "--task", "gown"])
    assert result.exit_code == 1
    assert result.output.startswith(f"Error: {path}: {message}"), result.output
    assert result.output.count("w.csv") == 1 and len(result.output.splitlines()) == 1
    assert not out.exists()


@pytest.mark.parametrize(
    ("header", "role"),
    [("Fx", "fx"), ("Force X (N)", "fx"), ("field.wrench.torque.z", "tz"), ("Mz [Nmm]", "tz"),
     ("%time", "time"), ("timestamp_ns", "time"), ("twist.linear.y", "vy"),
     ("field.pose.orientation.w", "qw"), ("pos_x", "x"), ("status", None), ("seq", None)],
)  # fmt: skip
def test_common_headers_are_recognised(header: str, role: str | None) -> None:
    assert role_of(header) == role


def test_bin_averaging_removes_vibration_that_decimation_would_alias() -> None:
    t_ns = times(1000, 1.0)
    grid = rs.grid(int(t_ns[0]) + 5_000_000, int(t_ns[-1]) - 5_000_000)
    noisy = wrench(seconds_of(t_ns))
    clean = wrench(seconds_of(grid), vibration=False)
    decimated = noisy[np.searchsorted(t_ns, grid)]
    assert np.abs(decimated - clean)[:, 2].max() > 0.1
    np.testing.assert_allclose(rs.bin_average(t_ns, noisy, grid), clean, atol=3e-4)


def test_velocity_from_pose_matches_the_derivative() -> None:
    t_ns = times(50, 2.0)
    np.testing.assert_allclose(
        rs.twist_from_pose(t_ns, pose(seconds_of(t_ns))), twist(seconds_of(t_ns)), atol=1e-4
    )
    two = np.array([0, 50_000_000])  # two poses 5 cm apart: 1 m/s, not the zero it was
    moved = np.array([[0, 0, 0, 0, 0, 0, 1], [0.05, 0, 0, 0, 0, 0, 1]], dtype=float)
    np.testing.assert_allclose(rs.twist_from_pose(two, moved)[:, 0], [1.0, 1.0])


def test_quaternion_sign_flips_do_not_disturb_interpolation() -> None:
    t_ns = times(50, 1.0)
    q = pose(seconds_of(t_ns))
    q[1::2, 3:] *= -1  # same rotations, alternate signs
    grid = rs.grid(int(t_ns[0]), int(t_ns[-1]))
    got = rs.interpolate_pose(t_ns, q, grid)
    want = pose(seconds_of(grid))
    sign = np.sign(np.einsum("ij,ij->i", got[:, 3:], want[:, 3:]))
    np.testing.assert_allclose(got[:, 3:] * sign[:, None], want[:, 3:], atol=1e-4)


def _with_velocity(path: Path, t: np.ndarray, header: str = "time") -> Path:
    names = [header, "fx", "fy", "fz", "tx", "ty", "tz", "vx", "vy", "vz"]
    return write_csv(path, names, [t, *wrench(t).T, *twist(t)[:, :3].T])


def test_gaps_are_listed_once_each_and_many_summed_up(tmp_path: Path) -> None:
    t = np.arange(3000) / 1000.0
    for k in range(8):  # eight 0.2 s holes in one file that holds wrench and velocity
        t = t[(t < 0.3 + 0.35 * k) | (t >= 0.5 + 0.35 * k)]
    with pytest.warns(ConversionWarning) as caught:
        report = convert(_with_velocity(tmp_path / "g.csv", t), tmp_path / "t.mcap", "gown")
    assert len(report.warnings) == len(caught) == 6
    assert len(set(report.warnings)) == 6 and all("g.csv" in w for w in report.warnings[:5])
    assert report.warnings[5].startswith("3 more gaps (the longest of all 0.201 s)")


def test_a_motion_file_covering_part_of_the_wrench_is_said(tmp_path: Path) -> None:
    t = np.arange(2000) / 1000.0
    forces = write_csv(tmp_path / "w.csv", ["time", "fx", "fy", "fz", "tx", "ty", "tz"],
                       [t, *wrench(t).T])  # fmt: skip
    part = t[(t >= 0.5) & (t < 1.5)]
    motion = write_csv(
        tmp_path / "m.csv", ["time", "vx", "vy", "vz"], [part, *twist(part)[:, :3].T]
    )
    with pytest.warns(ConversionWarning, match="the trial covers 0.99 s of the wrench's 2.00 s"):
        convert(forces, tmp_path / "t.mcap", "gown", motion=motion)


@pytest.mark.parametrize(
    ("options", "message"),
    [
        ({"wrench_topic": "/ft"}, "--wrench-topic: applies to bags, not to a CSV"),
        ({"columns": {"time": "stamp"}, "bag": True}, "--column: applies to a CSV, not to a bag"),
    ],
)
def test_an_option_for_the_other_kind_of_input_is_refused(
    tmp_path: Path, options: dict, message: str
) -> None:
    from tests.convert.signals import standard_topics, write_bag

    source = _with_velocity(tmp_path / "v.csv", np.arange(300) / 1000.0)
    if options.pop("bag", False):
        source = write_bag(tmp_path / "log.bag", standard_topics(), "ros1")
    with pytest.raises(ConversionError, match=message):
        convert(source, tmp_path / "t.mcap", "gown", **options)


def test_a_time_column_of_unset_stamps_points_to_another(tmp_path: Path) -> None:
    path = _with_velocity(tmp_path / "z.csv", np.zeros(300), header="stamp")
    with pytest.raises(ConversionError, match=r"every wrench timestamp is 0 ns \(unset\?\); pick"):
        convert(path, tmp_path / "t.mcap", "gown")


def test_microseconds_at_100_hz_with_no_unit_are_not_guessed_as_nanoseconds(
    tmp_path: Path,
) -> None:
    """Read as ns they would make a 100 kHz log, 1,000 times too short: ask instead."""
    t = np.arange(600) / 100.0
    path = _with_velocity(tmp_path / "us.csv", t)
    lines = path.read_text().splitlines()
    rows = [f"{round(float(r.split(',', 1)[0]) * 1e6)},{r.split(',', 1)[1]}" for r in lines[1:]]
    path.write_text("\n".join([lines[0], *rows]) + "\n")
    with pytest.raises(
        ConversionError, match=r"read as ns gives samples 1e-05 s apart.*--time-unit"
    ):
        convert(path, tmp_path / "t.mcap", "gown")
    assert convert(path, tmp_path / "t.mcap", "gown", time_unit="us").steps == 600  # 6 s at 100 Hz


def test_quoted_cells_are_read_as_their_numbers(tmp_path: Path) -> None:
    plain = _with_velocity(tmp_path / "p.csv", np.arange(300) / 1000.0)
    quoted = tmp_path / "q.csv"
    lines = plain.read_text().splitlines()
    rows = [", ".join(f'"{cell}"' for cell in row.split(",")) for row in lines[1:]]
    header = ", ".join(f'"{cell}"' for cell in lines[0].split(","))  # `", "` between cells
    quoted.write_text("\n".join([header, *rows]) + "\n")
    convert(plain, tmp_path / "p.mcap", "gown")
    convert(quoted, tmp_path / "q.mcap", "gown")
    np.testing.assert_array_equal(
        read_trial(tmp_path / "q.mcap").wrench.values, read_trial(tmp_path / "p.mcap").wrench.values
    )


def test_an_empty_cell_is_named_by_column_and_line(tmp_path: Path) -> None:
    path = _with_velocity(tmp_path / "e.csv", np.arange(300) / 1000.0)
    lines = path.read_text().splitlines()
    cells = lines[5].split(",")
    cells[2] = ""  # fy of the fifth data row, as a merged export leaves a slower topic's cells
    lines[5] = ",".join(cells)
    path.write_text("\n".join(lines) + "\n")
    with pytest.raises(ConversionError, match=r"column 'fy', line 6: '' is not a number"):
        convert(path, tmp_path / "t.mcap", "gown")


@pytest.mark.parametrize(
    ("cut", "what"),
    [
        ("1.999,0.5,0.2", "3 of 10 fields"),
        ("1.999,0.5,0.2,1,0,0,0,0.1,0,-", "its last field '-' is not a number"),
    ],
)
@prints_warnings
def test_a_last_line_cut_off_mid_write_is_dropped_with_a_warning(
    tmp_path: Path, cut: str, what: str
) -> None:
    """A logger killed mid-write: the whole file was refused with numpy's `at row 2000`
    (line 2001); only that line goes, and a short line inside the log names its line."""
    whole = _with_velocity(tmp_path / "whole.csv", np.arange(1999) / 1000.0)  # lines 2-2000
    path = tmp_path / "cut.csv"
    path.write_text(whole.read_text() + cut)  # no line end: the write never finished
    args = ["convert", str(path), "-o", str(tmp_path / "t.mcap"), "--task", "gown"]
    result = CliRunner().invoke(main, args)
    assert result.exit_code == 0, result.output
    assert result.output.splitlines()[0] == (
        f"Warning: cut.csv: line 2001 is incomplete ({what}), as a log cut off mid-write; dropped"
    )
    assert result.output.count("Warning") == 1
    convert(whole, tmp_path / "whole.mcap", "gown")
    np.testing.assert_array_equal(
        read_trial(tmp_path / "t.mcap").wrench.values,
        read_trial(tmp_path / "whole.mcap").wrench.values,
    )
    lines = whole.read_text().splitlines()
    inside = tmp_path / "inside.csv"
    inside.write_text("\n".join([*lines[:50], "0.049,0.5,0.2", *lines[51:]]) + "\n")
    refused = CliRunner().invoke(main, ["convert", str(inside), *args[2:], "--overwrite"])
    assert refused.exit_code == 1
    assert refused.output == (
        f"Error: {inside}: line 51 is incomplete (3 of 10 fields); only a last line cut off "
        "mid-write is dropped, so mend or remove this one\n"
    )


@pytest.mark.parametrize("style", ["ati", "rostopic"])
def test_a_csv_read_a_chunk_at_a_time_gives_the_trial_read_whole(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, style: str
) -> None:
    """A log's text was held whole (30 minutes at 1 kHz peaked at 1.1 GB); read 7 lines at a
    time, with blank and comment lines across a chunk's end and a cut last line followed by
    chunks of nothing, its trial is the same to the byte, nanosecond stamps kept exact."""
    path, motion = (ati_style(tmp_path), None) if style == "ati" else rostopic_style(tmp_path)
    lines = path.read_text().splitlines(keepends=True)
    lines[20:20] = ["\n", "# logger paused\n", "   \n"] * 4  # lines 21-32
    path.write_text("".join([*lines, lines[-1][:12] + "\n", "\n" * 20]))  # cut off, then blank
    trials = []
    for chunk in (csv_lines.CHUNK_LINES, 7):
        monkeypatch.setattr(csv_lines, "CHUNK_LINES", chunk)
        out = tmp_path / f"{chunk}.mcap"
        with pytest.warns(ConversionWarning, match=f"line {len(lines) + 1} is incomplete"):
            convert(path, out, "gown", motion=motion)
        trials.append(out.read_bytes())
    assert trials[0] == trials[1]


@pytest.mark.parametrize(
    ("fault", "message"),
    [
        ("short", "line 1506 is incomplete (3 of 10 fields); only a last line cut off mid-write "
         "is dropped, so mend or remove this one"),
        ("empty", "column 'fy', line 1506: '' is not a number (empty cells and decimal commas "
         "are not read)"),
        ("nan", "column 'time', line 1506: time 'nan' is not a finite number; drop that row"),
        ("empty above short", "line 2506 is incomplete (3 of 10 fields)"),
    ],
)  # fmt: skip
def test_a_bad_line_past_the_first_chunk_is_named_by_its_line(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, fault: str, message: str
) -> None:
    """Lines counted from the file's start, not the chunk's, blank and comment lines among
    them; and a short line further down is named before a cell that is no number above
    it, as when the file was read whole."""
    path = _with_velocity(tmp_path / "bad.csv", np.arange(3000) / 1000.0)
    lines = path.read_text().splitlines(keepends=True)
    cells = lines[1502].split(",")  # line 1503: in the fourth chunk of 500
    if fault == "short":
        lines[1502] = ",".join(cells[:3]) + "\n"
    else:
        cells[0 if fault == "nan" else 2] = "nan" if fault == "nan" else ""
        lines[1502] = ",".join(cells)
    if fault == "empty above short":
        lines[2502] = ",".join(lines[2502].split(",")[:3]) + "\n"
    lines[100:100] = ["# logger paused\n", "\n", "   \n"]  # the bad lines move 3 down
    path.write_text("".join(lines))
    monkeypatch.setattr(csv_lines, "CHUNK_LINES", 500)
    with pytest.raises(ConversionError) as raised:
        convert(path, tmp_path / "t.mcap", "gown")
    assert str(raised.value).startswith(f"{path}: {message}"), raised.value
    assert not (tmp_path / "t.mcap").exists()


@pytest.mark.parametrize(
    ("header", "unit"),
    [("Time (s)", "s"), ("time_ms", "ms"), ("Time [\u00b5s]", "us"), ("t (\u03bcs)", "us"),
     ("%time", "ns"), ("stamp[ns]", "ns"), ("time", None)],
)  # fmt: skip
def test_a_time_unit_written_in_the_header_is_read(header: str, unit: str | None) -> None:
    from dresslog.convert.csv import _unit_in

    assert _unit_in(header, Path("x.csv")) == unit


def test_decimal_commas_and_a_missing_header_are_named(tmp_path: Path) -> None:
    """What a spreadsheet in a German locale exports, and a logger that writes no header."""
    path = _with_velocity(tmp_path / "ft.csv", np.arange(500) / 1000.0)
    lines = path.read_text().splitlines()
    euro = tmp_path / "euro.csv"
    euro.write_text("\n".join(line.replace(",", ";").replace(".", ",") for line in lines))
    with pytest.raises(ConversionError, match=r"decimal commas \(line 2: .*decimal points"):
        convert(euro, tmp_path / "t.mcap", "gown")
    bare = tmp_path / "bare.csv"
    bare.write_text("\n".join(lines[1:]))
    with pytest.raises(ConversionError, match=r"has no header row \(line 1 is numbers\)"):
        convert(bare, tmp_path / "t.mcap", "gown")
    assert not (tmp_path / "t.mcap").exists()
    versioned = tmp_path / "versioned.csv"  # a number above the header is a preamble
    versioned.write_text("2\n" + "\n".join(lines))
    assert convert(versioned, tmp_path / "t.mcap", "gown").steps > 0


def test_a_preamble_above_the_header_is_passed_over(tmp_path: Path) -> None:
    """ATI's logger writes the sensor's serial number and calibration above the columns."""
    path = _with_velocity(tmp_path / "ati.csv", np.arange(500) / 1000.0)
    preamble = (
        "Serial Number:,FT12345\nCalibration:,FT12345 US-60-25\nRDT Sample Rate:,1000\n"
        "Tool Transform,0,0,0,0,0,0\n"  # a row of numbers, but not as wide as the data
    )
    path.write_text(preamble + path.read_text())
    report = convert(path, tmp_path / "t.mcap", "gown")
    assert report.steps == 49 and report.duration_s == 0.49  # 49 steps of 10 ms
    assert "time column 'time' read as s" in report.source["notes"][0]


ATI_PREAMBLE = """Start Time,11/14/2023 22:13:20
RDT Sample Rate,1000
Force Units,N
Counts per Unit Force,1000000
Torque Units,{torque}
Counts per Unit Torque,{per_torque}
"""


@pytest.mark.parametrize("wording", ["Counts per Unit {}", "Counts per {}:", "CountsPer{}"])
def test_ati_counts_are_scaled_by_the_preambles_counts_per_unit(
    tmp_path: Path, wording: str
) -> None:
    """ATI's Net F/T demo logs raw counts: read as newtons they are 10^6 too large. Its
    wordings differ (a .cal file's `CountsPerForce`); any but one was read as newtons."""
    t = np.arange(500) / 1000.0
    w = wrench(t)
    names = ["Status (hex)", "RDT Sequence", "Fx", "Fy", "Fz", "Tx", "Ty", "Tz", "Time"]
    raw = np.round(np.concatenate([w[:, :3] * 1e6, w[:, 3:] * 1e9], axis=1))  # whole counts
    counts = [np.full_like(t, 0), np.arange(500), *raw.T, t]
    path = write_csv(tmp_path / "ati.csv", names, counts)
    text = path.read_text()
    preamble = ATI_PREAMBLE.replace("Counts per Unit Force", wording.format("Force"))
    preamble = preamble.replace("Counts per Unit Torque", wording.format("Torque"))
    path.write_text(preamble.format(torque="N-mm", per_torque=1000000) + text)
    motion = write_csv(tmp_path / "v.csv", ["time", "vx", "vy", "vz"], [t, *twist(t)[:, :3].T])
    report = convert(path, tmp_path / "t.mcap", "gown", motion=motion)
    assert "force and torque are counts, scaled by the preamble" in " ".join(report.source["notes"])
    si = _with_velocity(tmp_path / "si.csv", t)
    convert(si, tmp_path / "si.mcap", "gown")
    np.testing.assert_allclose(
        read_trial(tmp_path / "t.mcap").wrench.values,
        read_trial(tmp_path / "si.mcap").wrench.values,
        rtol=0, atol=1e-6,
    )  # fmt: skip
    path.write_text(preamble.format(torque="kgf-cm", per_torque=1000) + text)
    with pytest.raises(ConversionError, match=r"torque columns are in counts \('1000' per "):
        convert(path, tmp_path / "u.mcap", "gown", motion=motion)


@pytest.mark.parametrize(
    ("preamble", "problem"),
    [  # each would leave counts read as newtons, or newtons divided by a million
        ("Force Units,N\nCounts per Unit Force,1000000\n", "counts per unit force but not torque"),
        ("Counts per Unit Force: 1000000\n", "counts per unit force but not torque"),
        ("Force Units=N\nCounts per Unit Force=inf\nTorque Units=N-m\n"
         "Counts per Unit Torque=1000000\n", "cannot scale"),
        ("Counts per unit force are written below\n", "mentions counts per unit"),
        ("Force Units,N\nCounts per Unit Force,1000000\nTorque Units,N-m\n"
         "Counts per Unit Torque,1000000\n", "is not a count"),  # the data are in N
    ],
)  # fmt: skip
def test_a_counts_preamble_that_cannot_be_applied_whole_is_refused(
    tmp_path: Path, preamble: str, problem: str
) -> None:
    path = _with_velocity(tmp_path / "n.csv", np.arange(300) / 1000.0)
    path.write_text(preamble + path.read_text().replace(",", ";"))  # its own separator
    with pytest.raises(ConversionError, match=problem):
        convert(path, tmp_path / "t.mcap", "gown")


def test_times_read_in_too_large_a_unit_point_to_time_unit(tmp_path: Path) -> None:
    """2 s at 1 kHz read as milliseconds: 2 ms, where "do not overlap" would mislead; and
    the unit it was given is named, where it had been told to give --time-unit."""
    with pytest.raises(ConversionError, match=r"log covers 0.002 s, .* in ms, as --time-unit ms"):
        convert(ati_style(tmp_path), tmp_path / "t.mcap", "gown", time_unit="ms")
    assert not (tmp_path / "t.mcap").exists()


@pytest.mark.parametrize(
    ("options", "code", "message"),
    [
        (["--rotate", "0", "0", "0", "0"], 1, "--rotate: a rotation quaternion is 4 finite"),
        (
            ["--rotate", *"0001", "--wrench-frame", "pose", "--sensor-rotation", *"0000"],
            1,
            "--sensor-rotation: a rotation quaternion is 4 finite",
        ),
        (["--tare", "10"], 1, "tare of 10.0 s is longer than the log (1.98 s); give a shorter"),
        (["--tare", "1e-10"], 1, "tare of 1e-10 s is shorter than one 0.01 s step"),
        (["--column", "fq=Fx (N)"], 1, "unknown column role 'fq'"),
        (["--tare", "-1"], 2, "Invalid value for '--tare': -1.0 is not in the range x>=0"),
        (["--column", "fx"], 2, "Invalid value for '--column': 'fx' is not ROLE=HEADER"),
        (
            ["--end", "5"],
            1,
            "--end 5 s is past the log's end: every stream covers 0-1.99 s of it; give --end "
            "1.99 or less",
        ),
        (["--start", "1.98"], 1, "--start 1.98 s leaves less than two steps of the log"),
        (["--start", "1", "--tare", "1.5"], 1, "tare of 1.5 s is longer than the window (0.98 s)"),
        (["--start", "1", "--end", "0.5"], 2, "--start 1 s is not before --end 0.5 s; give a"),
        (["--start", "1", "--end", "1.01"], 2, "holds less than two 100 Hz steps; give a window"),
        (["--start", "-1"], 2, "Invalid value for '--start': -1.0 is not in the range x>=0"),
        (["--end", "nan"], 2, "Invalid value for '--end': nan is not in the range x>=0"),
    ],
    ids=[
        "rotate",
        "sensor-rotation",
        "long-tare",
        "tiny-tare",
        "unknown-role",
        "negative-tare",
        "column-without-header",
        "end-past-the-log",
        "start-at-the-end",
        "tare-longer-than-the-window",
        "start-after-end",
        "window-of-one-step",
        "negative-start",
        "nan-end",
    ],
)
def test_bad_convert_options_are_one_line_or_usage_and_write_nothing(
    tmp_path: Path, options: list[str], code: int, message: str
) -> None:
    """Values only the log can judge are exit 1 in one line; malformed ones click's usage error."""
    source, out = ati_style(tmp_path), tmp_path / "t.mcap"
    args = ["convert", str(source), "-o", str(out), "--task", "gown", *options]
    result = CliRunner().invoke(main, args)
    assert result.exit_code == code and message in result.output, result.output
    if code == 1:
        assert len(result.output.splitlines()) == 1
    else:
        assert "Usage:" in result.output
    assert not out.exists()


def test_a_motion_file_from_another_time_is_said_not_to_overlap(tmp_path: Path) -> None:
    t_w, t_m = times(1000, 2.0), times(100, 2.0) + 60 * 10**9  # a minute later
    header = ["%time"] + [f"field.wrench.{q}.{a}" for q in ("force", "torque") for a in "xyz"]
    wrench_file = write_csv(tmp_path / "w.csv", header, [t_w, *wrench(seconds_of(t_w)).T])
    motion_header = ["%time"] + [f"field.pose.position.{a}" for a in "xyz"]
    motion_header += [f"field.pose.orientation.{a}" for a in "xyzw"]
    motion = write_csv(tmp_path / "m.csv", motion_header, [t_m, *pose(seconds_of(t_m)).T])
    with pytest.raises(
        ConversionError, match=r"do not overlap in time .* they must share one clock"
    ):
        convert(wrench_file, tmp_path / "t.mcap", "gown", motion=motion)


def test_a_nan_timestamp_is_named_by_its_line(tmp_path: Path) -> None:
    source = ati_style(tmp_path)
    lines = source.read_text().splitlines(keepends=True)
    lines[6] = "nan" + lines[6][lines[6].index(",") :]
    source.write_text("".join(lines))
    with pytest.raises(ConversionError, match=r"'Time \(s\)', line 7: time 'nan' is not a finite"):
        convert(source, tmp_path / "t.mcap", "gown")


def test_a_log_spanning_more_than_a_trial_is_refused_not_gridded(tmp_path: Path) -> None:
    """A first stamp of 0 before clock times asked for a grid of 10^11 steps (1.2 TiB)."""
    t = 1.7e9 + np.arange(200) / 100.0
    t[0] = 0.0
    path = _with_velocity(tmp_path / "zero_first.csv", t)
    with pytest.raises(ConversionError, match=r"the log spans 1\.7e\+09 s .* more than the 3600 s"):
        convert(path, tmp_path / "t.mcap", "gown")
    assert list(tmp_path.iterdir()) == [path]


def test_a_window_converts_as_the_log_cut_to_it_beforehand(tmp_path: Path) -> None:
    """--start 1 --end 3 of a 4 s log is the trial of its 1-3 s, times from 0."""
    t = np.arange(4000) / 1000.0
    whole = _with_velocity(tmp_path / "whole.csv", t)
    cut = _with_velocity(tmp_path / "cut.csv", t[(t >= 1.0) & (t <= 3.001)])  # a bin spare
    report = convert(whole, tmp_path / "w.mcap", "gown", start_s=1, end_s=3)
    convert(cut, tmp_path / "c.mcap", "gown")
    assert (report.steps, report.duration_s) == (200, 2.0)
    assert report.source["processing"]["window_s"] == [1.0, 3.0]
    summary = format_summary(summarize(tmp_path / "w.mcap"))
    assert "    kept    1-3 s of the time every stream covers" in summary.splitlines()
    with TrialReader(tmp_path / "w.mcap") as window, TrialReader(tmp_path / "c.mcap") as part:
        assert window.wrench.t_ns[0] == 0
        np.testing.assert_array_equal(window.wrench.t_ns, part.wrench.t_ns)
        np.testing.assert_allclose(window.wrench.values, part.wrench.values, atol=1e-9)
        np.testing.assert_allclose(window.twist.values, part.twist.values, atol=1e-9)


def test_the_tare_is_taken_from_the_windows_start(tmp_path: Path) -> None:
    """The garment hangs still at the start of the dressing, not of the session."""
    t = np.arange(4000) / 1000.0
    velocity = np.where((t >= 1.0) & (t < 1.6), 0.0, 0.2)  # still for 0.6 s from 1 s
    names = ["time", "fx", "fy", "fz", "tx", "ty", "tz", "vx", "vy", "vz"]
    source = write_csv(tmp_path / "s.csv", names, [t, *wrench(t).T, 0 * t, velocity, 0 * t])
    with pytest.warns(ConversionWarning, match=r"start is 5\.86 N, .* --tare 0\.6 \(the"):
        convert(source, tmp_path / "raw.mcap", "gown", start_s=1, end_s=3)
    convert(source, tmp_path / "tared.mcap", "gown", start_s=1, end_s=3, tare_s=0.5)
    raw, tared = read_trial(tmp_path / "raw.mcap"), read_trial(tmp_path / "tared.mcap")
    offset = raw.wrench.values[:50].mean(axis=0)  # the window's first 0.5 s
    np.testing.assert_allclose(tared.wrench.values, raw.wrench.values - offset, atol=1e-5)


def test_a_log_over_the_cap_converts_a_window_and_its_error_names_start_and_end(
    tmp_path: Path,
) -> None:
    """'convert it in parts of an hour or less' gave no way to; a gap past the window is
    not the trial's, so not warned about."""
    t = np.r_[np.arange(3000) / 1000.0, 7260.0]  # 3 s, then one sample 2 h later
    path = _with_velocity(tmp_path / "session.csv", t)
    args = ["convert", str(path), "-o", str(tmp_path / "t.mcap"), "--task", "gown"]
    whole = CliRunner().invoke(main, args)
    assert whole.exit_code == 1
    assert whole.output.startswith(f"Error: {path}: the log spans 7260 s (2 h 1 min) (")
    assert "trial may last: give --start and --end to convert an hour or less of it" in (
        whole.output
    )
    assert len(whole.output.splitlines()) == 1
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        window = CliRunner().invoke(main, [*args, "--start", "0.5", "--end", "2.5"])
    assert window.exit_code == 0, window.output
    assert f"{tmp_path / 't.mcap'}: 200 steps (2.00 s at 100 Hz)" in window.output
    with pytest.raises(ConversionError, match=r"--start 0.5 s leaves 7259 s \(2 h 1 min\) of"):
        convert(path, tmp_path / "u.mcap", "gown", start_s=0.5)
    with pytest.raises(ConversionError, match=r"--start 0 s to --end 7200 s is more than the"):
        convert(path, tmp_path / "u.mcap", "gown", end_s=7200)


def test_a_column_given_two_roles_is_refused(tmp_path: Path) -> None:
    """A typo in an axis swap (fx=Fy, fy=Fy) wrote a trial with one force axis lost."""
    source = _with_velocity(tmp_path / "s.csv", np.arange(500) / 1000.0)
    with pytest.raises(ConversionError, match="column 'fy' is given as both fx and fy"):
        convert(source, tmp_path / "t.mcap", "gown", columns={"fx": "fy", "fy": "fy"})
    assert not (tmp_path / "t.mcap").exists()


def test_a_role_mapped_twice_or_a_header_name_written_twice_is_refused_naming_it(
    tmp_path: Path,
) -> None:
    """Each was `no column recognised as fy`: the last --column fx won unsaid, and the
    second `Fx (N)` of a header was ignored as a column already placed."""
    source, out = ati_style(tmp_path), tmp_path / "t.mcap"
    args = ["convert", str(source), "-o", str(out), "--task", "gown"]
    twice = CliRunner().invoke(main, [*args, "--column", "fx=Fx (N)", "--column", "fx=Fy (N)"])
    assert twice.exit_code == 2, twice.output
    assert twice.output.splitlines()[-1] == (
        "Error: Invalid value for '--column': fx is given twice (fx=Fx (N), fx=Fy (N)); "
        "map each role to one column"
    )
    lines = source.read_text().splitlines(keepends=True)
    source.write_text(lines[0].replace("Fy (N)", "Fx (N)") + "".join(lines[1:]))
    header = CliRunner().invoke(main, args)
    assert header.exit_code == 1
    assert header.output == (
        f"Error: {source}: column 'Fx (N)' appears twice in the header (columns 2 and 3); "
        "rename one, as --column cannot tell them apart\n"
    )
    assert not out.exists()


def test_a_log_far_beyond_dressing_is_converted_with_a_warning_about_its_units(
    tmp_path: Path,
) -> None:
    """Raw counts or N mm without a unit in the header were read as SI without a word."""
    t = np.arange(500) / 1000.0
    names = ["time", "fx", "fy", "fz", "tx", "ty", "tz", "vx", "vy", "vz"]
    counts = write_csv(tmp_path / "c.csv", names, [t, *(wrench(t) * 1e6).T, *twist(t)[:, :3].T])
    with pytest.warns(ConversionWarning, match=r"force up to .*e\+06 N, torque up to .* N m, "):
        report = convert(counts, tmp_path / "t.mcap", "gown")
    assert "are the columns in SI units?" in report.warnings[-1]
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # a dressing robot's log: nothing to say
        convert(_with_velocity(tmp_path / "s.csv", t), tmp_path / "s.mcap", "gown")


@pytest.mark.parametrize(
    ("options", "message"),
    [
        ({"rotate": (0, 0, 1)}, "a rotation quaternion is 4 finite numbers"),
        ({"sensor_rotation": (0, 0, 0, 1, 0), "wrench_frame": "pose"}, "4 finite numbers"),
        ({"tare_s": None}, "tare of None s"),
        ({"max_gap_s": float("nan")}, "max_gap_s nan: give a duration above 0 s"),
        ({"max_gap_s": 0}, "max_gap_s 0: give a duration above 0 s"),
        ({"translate": (0.1, 0.2)}, "--translate: a translation is 3 finite numbers"),
        ({"translate": (0, 0, 2000)}, r"3 finite numbers, x y z \(metres\), each within \+-1000$"),
        (
            {"sensor_offset": (0, 0, 1e300), "wrench_frame": "pose"},
            "within \\+-2: the sensor is on",
        ),
        ({"translate": (0.1, 0.2, 0.3)}, "--translate moves the gripper's pose, which the log"),
    ],
)
def test_convert_called_from_a_script_says_what_is_wrong_with_its_options(
    tmp_path: Path, options: dict, message: str
) -> None:
    """Each was a ValueError or TypeError traceback, or a warning per sample."""
    with pytest.raises(ConversionError, match=message):
        convert(ati_style(tmp_path), tmp_path / "t.mcap", "gown", **options)
    assert not (tmp_path / "t.mcap").exists()


def test_a_csv_with_a_header_and_no_rows_is_one_line(tmp_path: Path) -> None:
    """numpy's own "input contained no data" warning stays out of it."""
    empty = tmp_path / "empty.csv"
    empty.write_text(
        "Time (s),Fx (N),Fy (N),Fz (N),Mx (Nm),My (Nm),Mz (Nm),vx (m/s),vy (m/s),vz (m/s)\n"
    )
    with warnings.catch_warnings(record=True) as shown:
        warnings.simplefilter("always")
        result = CliRunner().invoke(
            main, ["convert", str(empty), "-o", str(tmp_path / "e.mcap"), "--task", "gown"]
        )
    assert [str(w.message) for w in shown] == []
    assert result.exit_code == 1
    assert result.stderr == f"Error: {empty}: CSV has a header but no rows\n"
    assert not (tmp_path / "e.mcap").exists()


def test_two_columns_read_as_one_role_are_refused_until_one_is_named(tmp_path: Path) -> None:
    """`Fx (N)` and `Force X (N)` both read as fx: the second was dropped unsaid, so which
    force the trial got depended on the column order."""
    t = seconds_of(times(500, 1.0))
    header = ["Time (s)", "Fx (N)", "Force X (N)", "Fy (N)", "Fz (N)", "Mx (Nm)", "My (Nm)",
              "Mz (Nm)", "vx (m/s)", "vy (m/s)", "vz (m/s)"]  # fmt: skip
    w, v = wrench(t), twist(t)
    columns = [np.round(t, 6), w[:, 0] + 1.0, w[:, 0], *w[:, 1:].T, *v[:, :3].T]
    csv = write_csv(tmp_path / "two.csv", header, columns)
    args = ["convert", str(csv), "--task", "gown", "-o", str(tmp_path / "t.mcap")]
    refused = CliRunner().invoke(main, args)
    assert refused.exit_code == 1 and not (tmp_path / "t.mcap").exists()
    assert refused.output == (
        f"Error: {csv}: columns 'Fx (N)' and 'Force X (N)' both read as fx; name the one to "
        "use with --column fx=HEADER\n"
    )
    named = CliRunner().invoke(main, [*args, "--column", "fx=Force X (N)"])
    assert named.exit_code == 0, named.output
    with TrialReader(tmp_path / "t.mcap") as reader:
        got = reader.wrench.values[:, 0]
    assert abs(got.mean() - w[:, 0].mean()) < 0.05  # the named column, not the other (+1 N)


def test_a_header_with_a_trailing_delimiter_over_one_row_is_not_a_cut_off_line(
    tmp_path: Path,
) -> None:
    """The header's 11 cells (a trailing comma) above the only data row's 10 read as a row
    cut short; it is a log too short to convert, and says so."""
    csv = tmp_path / "one.csv"
    csv.write_text("time,Fx,Fy,Fz,Tx,Ty,Tz,vx,vy,vz,\n0.0,1,0,0,0,0,0,-0.1,0,0\n")
    args = ["convert", str(csv), "--task", "gown", "-o", str(tmp_path / "o.mcap")]
    result = CliRunner().invoke(main, args)
    assert result.exit_code == 1 and "only 1 wrench sample" in result.output, result.output


@pytest.mark.parametrize(("suffix", "sep", "blank"), [(".csv", ",", "   "), (".tsv", "\t", "\t\t")])
def test_a_last_line_of_spaces_or_tabs_is_blank(
    tmp_path: Path, suffix: str, sep: str, blank: str
) -> None:
    """numpy read it as a row of one empty cell: `cannot parse CSV: ... at row 1001`,
    counting data rows, or `'' is not a number`; an editor shows an empty line."""
    t = np.round(np.arange(0, 2, 0.002), 6)
    header = sep.join(["time", "Fx", "Fy", "Fz", "Tx", "Ty", "Tz", "vx", "vy", "vz"])
    rows = [sep.join(f"{v:g}" for v in (x, 1, 0, 0, 0, 0, 0, -0.1, 0, 0)) for x in t]
    log = tmp_path / f"log{suffix}"
    log.write_text("\n".join([header, *rows, blank]) + "\n")
    args = ["convert", str(log), "--task", "gown", "-o", str(tmp_path / "t.mcap")]
    result = CliRunner().invoke(main, args)
    assert result.exit_code == 0, result.output
    with TrialReader(tmp_path / "t.mcap") as reader:
        assert len(reader.wrench.t_ns) == 199 and reader.wrench.values[:, 0].mean() == 1.0


ROBOT = Path(__file__).resolve().parents[2] / "samples" / "robot"
#: The README's --rotate for samples/robot/ (-90 degrees about z), then the --translate that
#: takes the elbow, at (0.6, -0.1, 0.25) m in the robot's base frame, to the world's origin.
TO_SCENE = ["--rotate", "0", "0", "-0.7071068", "0.7071068", "--translate", "0.1", "0.6", "-0.25"]


def test_rotate_then_translate_puts_a_robots_gripper_path_on_the_scenes_limb(
    tmp_path: Path,
) -> None:
    """The bundled robot log's poses, in a base frame turned and moved from the world, come
    back onto the sample trial's gripper path (with --rotate alone they lay 0.6 m away, and
    the viewer drew the gripper off the limb); the estimate's signal is the same either way."""
    out = {name: tmp_path / f"{name}.mcap" for name in ("moved", "turned")}
    args = ["convert", str(ROBOT / "ft.csv"), "--motion", str(ROBOT / "pose.csv"), "--task",
            "gown", "--wrench-frame", "pose", "--tare", "0.5"]  # fmt: skip
    moved = CliRunner().invoke(main, [*args, "-o", str(out["moved"]), *TO_SCENE])
    assert moved.exit_code == 0 and not moved.stderr, moved.output
    turned = CliRunner().invoke(main, [*args, "-o", str(out["turned"]), *TO_SCENE[:5]])
    assert turned.exit_code == 0, turned.output
    sample = read_trial(Path(__file__).resolve().parents[2] / "samples" / "gown.mcap")
    with TrialReader(out["moved"]) as log:
        pose, phi = log.pose.values, log.measurements.phi
        processing = log.metadata.source["processing"]
    hold = len(pose) - len(sample.pose.values)  # the gown hanging still first
    assert hold == 100
    np.testing.assert_allclose(pose[hold:, :3], sample.pose.values[:, :3], atol=1e-5)
    assert processing["translation_m"] == [0.1, 0.6, -0.25]
    np.testing.assert_array_equal(phi, read_trial(out["turned"]).measurements.phi)


@prints_warnings
def test_a_robots_log_converted_without_its_tare_is_warned_about(tmp_path: Path) -> None:
    """Untared, the bundled log's 2.5 N of hanging gown read as force on the arm on 99% of
    steps, not 52%, and `infer` could not tell: a garment's weight is within its training."""
    args = ["convert", str(ROBOT / "ft.csv"), "--motion", str(ROBOT / "pose.csv"), "-o",
            str(tmp_path / "t.mcap"), "--overwrite", "--task", "gown", "--wrench-frame", "pose",
            *TO_SCENE]  # fmt: skip
    said = {tare: CliRunner().invoke(main, [*args, "--tare", tare]) for tare in ("0", "0.5")}
    assert all(result.exit_code == 0 for result in said.values())
    assert said["0"].stderr == (
        "Warning: the force while the gripper is still at the start is 2.45 N, where the "
        "simulated trials start near 0 (tared with the garment hanging); if the sensor was not "
        "zeroed with the garment hanging, convert with --tare 1 (the still start here)\n"
    )
    assert not said["0.5"].stderr


def _held_then_moving(path: Path, hold_s: float, weight: float) -> Path:
    """A 1 kHz log whose gripper holds still for its first `hold_s`, then moves, with `weight`
    N more in fz throughout (0: a sensor zeroed with the garment hanging). The motion starts
    5 ms on, inside the converted step at `hold_s`, not on its 10 ms bin's edge."""
    t = np.arange(2000) / 1000.0
    moving = (t >= hold_s + 0.005)[:, None]
    force = np.where(moving, wrench(t), 0.0) + np.array([0, 0, weight, 0, 0, 0])
    velocity = np.where(moving, twist(t)[:, :3], 0.0)
    names = ["time", "fx", "fy", "fz", "tx", "ty", "tz", "vx", "vy", "vz"]
    return write_csv(path, names, [t, *force.T, *velocity.T])


@pytest.mark.parametrize(
    ("hold_s", "weight", "tare_s", "message"),
    [
        (0.5, 2.0, 0.0, r"^the force while .* still at the start is 2\.00 N, .* --tare 0\.5 \("),
        (0.5, 0.0, 0.0, None),  # tared with the garment hanging
        (0.5, 0.4, 0.0, None),  # a sensor's drift, or a garment under 40 g
        (0.1, 2.0, 0.0, None),  # a pause as the motion begins: no still start to tare by
        (0.5, 2.0, 0.5, None),
        (0.3, 2.0, 0.5, r"^the gripper starts moving at 0\.30 s, .* --tare 0\.3 or less keeps"),
        (0.0, 0.0, 0.5, r"^the gripper moves from the first step, so the tare's 0\.5 s take in"),
    ],
    ids=["untared", "tared", "drift", "pause", "tare-still", "tare-into-motion", "no-still"],
)
def test_a_tare_left_out_or_reaching_into_the_motion_is_warned_about(
    tmp_path: Path, hold_s: float, weight: float, tare_s: float, message: str | None
) -> None:
    source = _held_then_moving(tmp_path / "h.csv", hold_s, weight)
    if message is None:
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            convert(source, tmp_path / "t.mcap", "gown", tare_s=tare_s)
        return
    with pytest.warns(ConversionWarning, match=message):
        report = convert(source, tmp_path / "t.mcap", "gown", tare_s=tare_s)
    assert report.warnings == report.source["warnings"] and len(report.warnings) == 1


def test_options_passed_whole_or_as_keywords_make_the_same_trial(tmp_path: Path) -> None:
    """`ConvertOptions` is what the command builds and passes whole; a Python caller's
    keywords build the same one, so both make the same file."""
    from dresslog.convert import ConvertOptions, SignalOptions

    robot = SAMPLES / "robot"
    keywords = {"motion": robot / "pose.csv", "wrench_frame": "pose", "tare_s": 0.5,
                "rotate": (0.0, 0.0, -0.7071068, 0.7071068)}  # fmt: skip
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ConversionWarning)
        convert(robot / "ft.csv", tmp_path / "keywords.mcap", "gown", **keywords)
        signal = SignalOptions(wrench_frame="pose", tare_s=0.5, rotate=keywords["rotate"])
        whole = ConvertOptions(task="gown", motion=keywords["motion"], signal=signal)
        assert whole == ConvertOptions.build("gown", **keywords)
        convert(robot / "ft.csv", tmp_path / "whole.mcap", whole)
    made = [read_trial(tmp_path / f"{name}.mcap") for name in ("keywords", "whole")]
    np.testing.assert_array_equal(made[0].measurements.phi, made[1].measurements.phi)
    assert made[0].metadata.source == made[1].metadata.source
    with pytest.raises(TypeError, match="tare_s"):
        convert(robot / "ft.csv", tmp_path / "both.mcap", whole, tare_s=1.0)


def test_convert_and_live_take_one_set_of_signal_options() -> None:
    """The frame, mount, axis and tare options are one decorator and one SignalOptions."""
    import click

    from dresslog.convert import SignalOptions

    ctx = click.Context(main)
    commands = [main.get_command(ctx, name) for name in ("convert", "live")]
    shared = set(SignalOptions.model_fields) - {"max_gap_s"}
    described = [
        {p.name: (p.opts, p.help, p.default) for p in c.params if p.name in shared}
        for c in commands
        if c is not None
    ]
    assert set(described[0]) == shared and described[0] == described[1]
