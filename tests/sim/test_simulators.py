"""Simulator versions: v9 by default, v8 and v7 by name, each as it always recorded;
v9's outcomes and a folder's fidelity figures."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from dresslog.cli.main import main
from dresslog.dataset.manifest import Split, trial_seed
from dresslog.io import TrialReader
from dresslog.limb import build_limb
from dresslog.sim import random_spec, record_trial
from dresslog.sim.outcome import CatchWatch
from dresslog.spec import RECORDED, SimParams, Task, TrialSpec, simulator_name

#: The spec of simulator v8's gown sample (seed 4), as its file saved it before v9.
V8_GOWN = {
    "task": "gown", "seed": 4, "speed": 0.10404180119478011,
    "limb_offset": [0.044305610557236766, 0.004531021125744639, 0.09524874114154083],
    "limb_rotation": {"axis": "z", "degrees": 0.0}, "duration": 1.0,
    "control_points": [
        [0.62, 0.0, 0.1], [0.5354463379197791, 0.01207604827943229, 0.06745278161440285],
        [0.4880124021655451, 0.001757656030539927, 0.14022150797159885],
        [0.38720064000178095, -0.002780148890823475, 0.12889467175443295],
        [0.34047775142443865, -0.005210968293902849, 0.1468932869316235],
        [0.2600272975516394, -0.012892296569520756, 0.11088516168445477],
        [0.16943474187674162, 0.017712147165166687, 0.11656574169657535], [0.08, 0.0, 0.1],
    ],
    "sim": {"physics_hz": 300, "record_hz": 100, "settle_s": 1.0, "wind_s": 0.3,
            "wind_accel": 2.0, "garment_mass": 0.25, "elastic_stiffness": 40.0,
            "damping_stiffness": 1.0, "bending_stiffness": 2.0, "friction": 0.5,
            "collision_margin": 0.006, "contact_spread": 3, "contact_reach": 0.012,
            "grip_clearance": 0.01, "max_grip_lift": 0.1, "lift_smoothing": 0.25,
            "max_limb_force": 200.0, "wrench_from": "momentum"},
}  # fmt: skip
#: Its wrench at step 99 and the sum of |wrench| over its first 100 steps, as v8 recorded.
V8_STEP_99 = [-0.056735302478660196, 0.08059345155645253, -0.13269468392401773,
              0.006950947199005118, 0.019249294299245268, 0.012914499454497784]  # fmt: skip
V8_SUM_100 = 48.38568739151393


@pytest.mark.slow
def test_a_v8_spec_read_from_a_file_records_what_v8_recorded(tmp_path: Path) -> None:
    """A spec saved before v9 (no simulator named) is v8's, and simulates bit for bit as
    v8 did: its garment, grip, cloth and path are still there for old data."""
    spec = TrialSpec.model_validate(V8_GOWN, context=RECORDED)
    assert simulator_name(spec.sim) == "v8"
    record_trial(spec, tmp_path / "v8.mcap")
    with TrialReader(tmp_path / "v8.mcap") as trial:
        wrench = trial.wrench.values[:100]
    assert wrench[99].tolist() == V8_STEP_99
    assert float(np.abs(wrench).sum()) == V8_SUM_100


def test_record_and_the_library_default_to_one_simulator() -> None:
    """One default: `random_spec` and `SimParams()` are what `record` records (v9)."""
    assert simulator_name(random_spec(Task.GOWN, 1).sim) == "v9"
    assert SimParams() == random_spec(Task.GOWN, 1, sim={"simulator": 9}).sim
    # the momentum balance's wrench, which the bundled models read; the constraint's is v7's
    assert SimParams().wrench_from == "momentum"
    v8 = random_spec(Task.GOWN, 1, sim={"simulator": 8})
    assert (v8.sim.damping_stiffness, v8.sim.bending_stiffness) == (1.0, 2.0)
    # v8 drew its offsets over the paper's numbers on our axes, v9 over its frame mapped
    assert v8.limb_offset != random_spec(Task.GOWN, 1).limb_offset


def _watch_gown(force: float, on: str, seconds: float, speed: float = 0.1) -> str | None:
    limb = build_limb(Task.GOWN)
    watch = CatchWatch(Task.GOWN, limb, 100)
    names = limb.segment_names
    where = {"fist": limb.spheres["fist"].center, "forearm": np.array([0.2, 0.0, -0.04])}
    for _ in range(round(seconds * 100)):
        watch.step(speed, force, where[on][None], np.array([names.index(on)]), np.array([1.0]))
    return watch.finish()


def test_a_catch_is_a_held_pull_on_a_catching_part() -> None:
    """Held on the fist for 0.3 s while the gripper pulls with over 2 N: caught on the
    fist. Shorter, weaker, with the gripper still, or on the forearm: no catch."""
    assert _watch_gown(3.0, "fist", 0.5) == "fist"
    assert _watch_gown(3.0, "fist", 0.2) is None
    assert _watch_gown(1.0, "fist", 1.0) is None
    assert _watch_gown(3.0, "fist", 1.0, speed=0.0) is None
    assert _watch_gown(3.0, "forearm", 1.0) is None


@pytest.mark.slow
def test_a_caught_shorts_trial_names_the_foot_and_info_states_the_folders_fidelity(
    tmp_path: Path,
) -> None:
    """A shorts trial whose leg opening holds on the foot while the gripper pulls is
    caught there, in its metadata and in `info`; `info DATA` states the outcome mix,
    where the force falls and the force scale beside the paper's."""
    from dresslog.dataset import Execution, generate

    spec = random_spec(Task.SHORTS, 7, limb_offset=(-0.038, -0.047, -0.039))
    result = record_trial(spec, tmp_path / "caught.mcap")
    assert (result.outcome.value, result.caught_on) == ("caught", "foot")
    shown = CliRunner().invoke(main, ["info", str(tmp_path / "caught.mcap")])
    assert "outcome caught on the foot" in shown.output
    data = tmp_path / "d"
    generate("shorts", 2, data, test_fraction=1, overrides={"duration": 1.0},
             execution=Execution(workers=2), progress=False)  # fmt: skip
    shown = CliRunner().invoke(main, ["info", str(data)])
    assert shown.exit_code == 0, shown.output
    lines = shown.output.splitlines()
    assert lines[3:5] == ["  fidelity  against the paper's dressing", lines[4]]
    assert lines[4].startswith("  outcomes  ")
    assert "(the all-zero RMSE; paper 0.102 N" in lines[5]
    listed = json.loads(CliRunner().invoke(main, ["info", str(data), "--json"]).output)
    assert listed["fidelity"]["trials_read"] == 2
    assert listed["fidelity"]["paper_zero_rmse"] == 0.102


def test_v10_is_asked_for_by_name_and_changes_both_paths() -> None:
    """v10 draws the gown's sleeve up beside the upper arm on a smoother cloth, and the
    shorts' waist higher over the foot into slimmer legs; its offsets and path
    deviations are v9's."""
    from dresslog.sim.garments import garment_for
    from dresslog.spec import oldest_first, simulator_fields, simulator_of

    assert simulator_fields("v10") == {"simulator": 10}
    assert simulator_of(simulator_fields("v10")) == "v10"
    assert sorted(["v10", "v7", "v9", "v8"], key=oldest_first) == ["v7", "v8", "v9", "v10"]
    v9, v10 = {"simulator": 9}, {"simulator": 10}
    gown9, gown10 = (random_spec(Task.GOWN, 3, sim=s) for s in (v9, v10))
    assert gown9.limb_offset == gown10.limb_offset and gown9.speed == gown10.speed
    # the path leaves the forearm's plane for the upper arm's side, and ends behind it
    assert max(p[1] for p in gown10.control_points) > 0.08 > max(p[1] for p in gown9.control_points)
    assert gown10.control_points[-1][0] < 0 < gown9.control_points[-1][0]
    assert (garment_for(Task.GOWN, 10).friction, garment_for(Task.GOWN, 9).friction) == (0.3, 0.5)
    shorts9, shorts10 = (random_spec(Task.SHORTS, 3, sim=s) for s in (v9, v10))
    assert shorts9.limb_offset == shorts10.limb_offset and shorts9.speed == shorts10.speed
    # over the foot 4 cm higher, then the same along the leg
    rise = np.array(shorts10.control_points)[:2, 2] - np.array(shorts9.control_points)[:2, 2]
    assert np.allclose(rise, 0.04), rise
    a, b = garment_for(Task.SHORTS, 10), garment_for(Task.SHORTS, 9)
    leg_width = [np.ptp(g.vertices[g.exit_rim, 1]) for g in (a, b)]
    assert np.allclose(leg_width, [0.16, 0.18], atol=0.005), leg_width
    assert (a.friction, a.elastic_stiffness) == (b.friction, b.elastic_stiffness)


#: The seed of trial 49 of `generate --task gown --seed 900 --trials 120 --test-fraction 1`.
FRESH_49 = trial_seed(900, Split.TEST, 49)


@pytest.mark.slow
def test_a_v10_gown_trial_slides_its_sleeve_up_the_upper_arm(tmp_path: Path) -> None:
    """Trial 49 of the gown's fresh set (docs/simulator.md's picture): v9 dresses it
    with its force on the forearm, v10 draws the sleeve round the elbow, where it is
    caught, and up the upper arm. v10's cloth slides at its own friction, which a spec
    may still set."""
    from dresslog.dataset.fidelity import trial_figures
    from dresslog.spec import simulator_fields

    shares, outcomes = {}, {}
    for name in ("v9", "v10"):
        spec = random_spec(Task.GOWN, FRESH_49, sim=simulator_fields(name))
        result = record_trial(spec, tmp_path / f"{name}.mcap")
        outcomes[name] = (result.outcome.value, result.caught_on)
        parts = trial_figures(tmp_path / f"{name}.mcap").region_impulse  # what `info` sums
        shares[name] = (parts["upper_arm"] + parts["elbow"]) / sum(parts.values())
    assert outcomes == {"v9": ("dressed", None), "v10": ("caught", "elbow")}
    assert shares["v9"] < 0.01 and shares["v10"] > 0.4, shares
    rough = random_spec(Task.GOWN, FRESH_49, sim={"simulator": 10, "friction": 0.5})
    assert rough.sim.friction == 0.5 and random_spec(Task.GOWN, 1).sim.friction is None
