"""The commands besides calibrate (simulate, validate, compensate, accuracy,
plan, export) from Python against the parcal binary."""

import json
import re
import shutil

import numpy as np
import pytest

import parcal
from conftest import ROOT


def test_simulate_makes_the_dataset_of_the_cli(tmp_path, cli):
    cli("simulate", "--seed", 3, "--balls", 40, "--points-per-ball", 5, "--tilt", 15, "--out", tmp_path / "cli")
    mine = parcal.simulate(3, balls=40, points_per_ball=5, tilt=15)
    theirs = parcal.Dataset.read(tmp_path / "cli")
    assert mine.checksum == theirs.checksum
    assert mine.contacts == 200 and np.array_equal(mine.q, theirs.q)
    with pytest.raises(parcal.Error, match=r"tilt must be in \[0, 90\) degrees, got 90"):
        parcal.simulate(1, tilt=90)
    # A ball plate: five pairs drawn, 2 um; the contacts those without it.
    cli("simulate", "--seed", 3, "--balls", 8, "--plate", 5, "--plate-sigma", 2, "--out", tmp_path / "plate")
    plated = parcal.simulate(3, balls=8, plate=5, plate_sigma=2)
    assert plated.checksum == parcal.Dataset.read(tmp_path / "plate").checksum
    assert np.array_equal(plated.q, parcal.simulate(3, balls=8).q)
    with pytest.raises(parcal.Error, match=r"plate: a plate needs at least 1 pair"):
        parcal.simulate(3, balls=8, plate=0)


def validation_json(path):
    record = json.loads(path.read_text())
    del record["format"]
    return record


def test_validate_a_calibration_of_touches_as_the_cli(paper, cli):
    calibration = paper.parent / "calibration.json"
    cli("calibrate", paper, "--out", calibration)
    cli("validate", paper, "--calibration", calibration, "--reference", 4, "--out", paper.parent / "v.json")
    dataset = parcal.Dataset.read(paper)
    mine = parcal.validate(dataset, calibration=str(calibration), reference=4)
    assert mine == validation_json(paper.parent / "v.json")
    assert mine["verdict"] in ("accepted", "rejected")
    with pytest.raises(parcal.Error, match="give calibration or folds"):
        parcal.validate(dataset)


def test_cross_validate_jugglebot_as_the_cli(tmp_path, cli):
    path = tmp_path / "jugglebot"
    shutil.copytree(ROOT / "fixtures" / "jugglebot", path)
    cli("validate", path, "--folds", 3, "--out", tmp_path / "v.json")
    mine = parcal.validate(parcal.Dataset.read(path), folds=3)
    assert mine == validation_json(tmp_path / "v.json")
    with pytest.raises(parcal.Error, match=r"folds 1: must be a whole number"):
        parcal.validate(parcal.Dataset.read(path), folds=1)


def test_compensate_gives_the_commands_of_the_cli(paper, cli, tmp_path):
    calibration = tmp_path / "calibration.json"
    cli("calibrate", paper, "--out", calibration)
    targets = np.array([[10.0 * k, -5.0 * k, 400.0 + k, 0.01 * k, -0.02, 0.005 * k] for k in range(5)])
    np.savetxt(tmp_path / "targets.csv", targets, delimiter=",", header="x,y,z,roll,pitch,yaw", comments="", fmt="%.17g")
    cli("compensate", "--calibration", calibration, "--poses", tmp_path / "targets.csv",
        "--out", tmp_path / "q.csv", "--corrected-poses", tmp_path / "corrected.csv")
    mine = parcal.compensate(str(calibration), targets)
    assert np.array_equal(mine["q"], np.loadtxt(tmp_path / "q.csv", delimiter=",", skiprows=1))
    assert np.array_equal(mine["corrected_poses"], np.loadtxt(tmp_path / "corrected.csv", delimiter=",", skiprows=1))
    assert np.all((mine["conditioning"] > 0) & (mine["conditioning"] <= 1))
    targets[3, 2] = 5000.0
    with pytest.raises(parcal.Error, match=r"target row 3: "):
        parcal.compensate(parcal.calibrate(parcal.Dataset.read(paper)), targets)


def test_accuracy_gives_the_maps_of_the_cli(paper, cli, tmp_path):
    calibration = tmp_path / "calibration.json"
    cli("calibrate", paper, "--out", calibration)
    cli("accuracy", paper, "--calibration", calibration, "--out", tmp_path / "maps")
    with open(tmp_path / "maps" / "accuracy.csv") as f:
        header = f.readline().strip().split(",")
    table = np.loadtxt(tmp_path / "maps" / "accuracy.csv", delimiter=",", skiprows=1)
    mine = parcal.accuracy(parcal.Dataset.read(paper), str(calibration))
    assert np.array_equal(np.meshgrid(mine["x"], mine["y"])[0].ravel(), table[:, 0])
    for k, column in enumerate(header[2:], start=2):
        assert np.array_equal(mine[column.removesuffix("_mm")].ravel(), table[:, k]), column
    other = parcal.simulate(5)
    with pytest.raises(parcal.Error, match=r"the calibration is of another dataset"):
        parcal.accuracy(other, str(calibration))
    assert set(parcal.accuracy(other)) == {"x", "y", "z"} | {
        f"before_{m}_{k}" for m in ("predicted", "true") for k in ("absolute", "registered")
    }


def test_plan_chooses_the_touches_of_the_cli(paper, cli, tmp_path):
    cli("plan", paper, "--contacts", 40, "--tilt", 20, "--pool", 1000, "--out", tmp_path / "plan.csv")
    table = np.loadtxt(tmp_path / "plan.csv", delimiter=",", skiprows=1, usecols=range(1, 13))
    balls = np.loadtxt(tmp_path / "plan.csv", delimiter=",", skiprows=1, usecols=0, dtype=str)
    summary = json.loads((tmp_path / "plan.json").read_text())
    mine = parcal.plan(parcal.Dataset.read(paper), 40, 20, pool=1000)
    assert mine["ball"] == list(balls)
    assert np.array_equal(np.hstack([mine["direction"], mine["angles"], mine["q"]]), table)
    assert mine["predicted"] == summary["predicted"] and mine["pool_size"] == summary["pool_size"]
    with pytest.raises(parcal.Error, match=r'criterion: "e" is not one of registered, d, a, g'):
        parcal.plan(parcal.Dataset.read(paper), 40, 20, criterion="e")


def pose_plan_files(path):
    """A pose plan.csv's session labels and numbers, and its plan.json."""
    sessions = np.loadtxt(path, delimiter=",", skiprows=1, usecols=0, dtype=str, ndmin=1)
    table = np.loadtxt(path, delimiter=",", skiprows=1, usecols=range(1, 13), ndmin=2)
    return list(sessions), table, json.loads(path.with_suffix(".json").read_text())


def test_plan_chooses_the_poses_of_the_cli(tmp_path, cli, cli_output):
    # Jugglebot: machine.json and poses, no balls: a plan of poses by default.
    jugglebot = ROOT / "fixtures" / "jugglebot"
    cli("plan", jugglebot, "--poses", 8, "--tilt", 10, "--workspace", "30,200,260", "--out", tmp_path / "plan.csv")
    sessions, table, summary = pose_plan_files(tmp_path / "plan.csv")
    mine = parcal.plan(parcal.Dataset.read(jugglebot), tilt=10, poses=8, workspace=(30, 200, 260))
    assert mine["session"] == sessions == ["1"] * 8
    assert np.array_equal(np.hstack([mine["angles"], mine["tip"], mine["q"]]), table)
    assert {k: mine[k] for k in ("prior", "predicted", "pool_size")} == {
        k: summary[k] for k in ("prior", "predicted", "pool_size")
    }
    assert mine["predicted"]["registered_rms_um"] < mine["prior"]["registered_rms_um"]
    # A dataset with balls plans poses when asked: points, two sessions, D-optimal.
    mixed = tmp_path / "mixed"
    cli("simulate", "--seed", 1, "--tracker", "both", "--touches", "--out", mixed)
    flags = ("--tracker", "points", "--criterion", "d", "--tilt", 10, "--workspace", "40,340,400")
    cli("plan", mixed, *flags, "--sessions", 2, "--poses", 6, "--out", tmp_path / "points.csv")
    sessions, table, summary = pose_plan_files(tmp_path / "points.csv")
    dataset = parcal.Dataset.read(mixed)
    options = dict(tilt=10, tracker="points", criterion="d", workspace=(40, 340, 400))
    mine = parcal.plan(dataset, poses=6, sessions=2, **options)
    assert mine["session"] == sessions == ["1", "1", "1", "2", "2", "2"]
    assert np.array_equal(np.hstack([mine["angles"], mine["tip"], mine["q"]]), table)
    assert mine["predicted"] == summary["predicted"] and mine["prior"] == summary["prior"]
    # The command's refusals, in Python's words.
    uneven = cli_output("plan", mixed, *flags, "--sessions", 2, "--poses", 7, "--out", tmp_path / "x.csv")
    with pytest.raises(parcal.Error, match="7 poses in 2 sessions: the sessions must share the poses evenly") as e:
        parcal.plan(dataset, poses=7, sessions=2, **options)
    assert uneven.returncode == 1 and str(e.value) in uneven.stderr
    for bad, message in [
        (dict(poses=0), r"poses 0: must be a whole number from 1 to 1000 \("),
        (dict(poses=6, sessions=101), r"sessions 101: must be a whole number from 1 to 100 \("),
        (dict(poses=6, min_balls=2), r"^after, per_ball, min_balls and radius apply to ball touches only$"),
        (dict(poses=6, tracker="pose"), r'^tracker: "pose" is not one of poses, points, both$'),
        (dict(poses=6, workspace=(40, 400, 340)), r"^workspace: \(40, 400, 340\) is not three finite numbers"),
        (dict(poses=6, workspace=None), r"^workspace=\(half_width, z_min, z_max\) is needed for a pose plan$"),
        (dict(contacts=6), r"^poses is needed for a pose plan \(tracker=, or a dataset without balls\)$"),
        (dict(poses=6, tilt=None), r"^tilt is needed for a hexapod's plan$"),
    ]:
        with pytest.raises(parcal.Error, match=message):
            parcal.plan(dataset, **{**options, **bad})
    with pytest.raises(parcal.Error, match=r"^sessions applies to pose plans only \(tracker=\)$"):
        parcal.plan(dataset, 40, 10, sessions=2)
    with pytest.raises(parcal.Error, match=r"^contacts cannot be used with poses"):
        parcal.plan(dataset, 40, 10, poses=6)


TABLE_HEADER = ["x", "y", "z", "roll", "pitch", "yaw", "dx", "dy", "dz", "droll", "dpitch", "dyaw"]
PRINTED_TABLE = re.compile(
    r"correction table: (\d+) nodes -> .*; multilinear interpolation error at the (\d+) cell midpoints: "
    r"position RMS (\S+) um, max (\S+) um; angles max (\S+) rad"
)


def test_correction_table_gives_the_table_of_the_cli(paper, cli, cli_output, tmp_path):
    calibration = tmp_path / "calibration.json"
    cli("calibrate", paper, "--out", calibration)
    axes = dict(x=(-100, 100, 5), y=(-80, 80, 3), z=(360, 440, 3), roll=(-0.05, 0.05, 2))
    spec = ",".join(f"{axis}={low}:{high}:{n}" for axis, (low, high, n) in axes.items())
    tables = {}
    for nominal in (False, True):
        out = tmp_path / f"table-{nominal}.csv"
        done = cli_output("compensate", "--calibration", calibration, "--table", spec, "--out", out,
                          *(["--nominal"] if nominal else []))
        assert done.returncode == 0, done.stderr
        mine = tables[nominal] = parcal.correction_table(str(calibration), nominal=nominal, **axes)
        assert out.read_text().splitlines()[0].split(",") == TABLE_HEADER
        table = np.loadtxt(out, delimiter=",", skiprows=1)
        assert table.shape == (90, 12) and mine["shape"] == (5, 3, 3, 2, 1, 1)
        for k, column in enumerate(TABLE_HEADER):
            assert np.array_equal(mine[column], table[:, k]), column
        printed = PRINTED_TABLE.search(done.stdout)
        assert printed, done.stdout
        assert int(printed[1]) == 90 and int(printed[2]) == mine["points"] == 4 * 2 * 2
        assert printed[3] == f"{1e3 * mine['position_rms']:.2f}"
        assert printed[4] == f"{1e3 * mine['position_max']:.2f}"
        assert float(printed[5]) == float(f"{mine['angle_max']:.2e}")
    # The calibrated machine's corrections are tenths of a millimetre, the
    # interpolation's error far less; the design's own corrections are nil.
    calibrated, nominal = tables[False], tables[True]
    assert 0.05 < np.abs(calibrated["dx"]).max() < 1 and calibrated["position_max"] < 0.05
    assert np.abs(nominal["dx"]).max() < 1e-9 and nominal["position_max"] < 1e-9
    # An in-memory calibration gives the same table as its file.
    run = parcal.calibrate(parcal.Dataset.read(paper))
    assert all(np.array_equal(parcal.correction_table(run, **axes)[c], calibrated[c]) for c in TABLE_HEADER)
    # Refusals name the argument; the library's as the command words them.
    refused = cli_output("compensate", "--calibration", calibration, "--table", "x=1:0:3", "--out", tmp_path / "t.csv")
    with pytest.raises(parcal.Error, match="axis x is not strictly increasing") as e:
        parcal.correction_table(str(calibration), x=(1, 0, 3))
    assert refused.returncode == 1 and str(e.value) in refused.stderr
    for bad, message in [
        (dict(x=(0, 1, 0)), r"^x: n 0: must be a whole number from 1 to 10000000 \("),
        (dict(y=(0, 1, 10000), yaw=(0, 1, 10000)),
         r"^x 1 x y 10000 x z 1 x roll 1 x pitch 1 x yaw 10000 make more than 10000000 nodes"),
        (dict(pitch=(0, 1)), r"^pitch: expected \(min, max, n\) with n a whole number, got \(0, 1\)$"),
        (dict(z=(5000, 5000, 1)), r"^the correction table: row 0: "),
        (dict(), r"^no axis given: one of x, y, z, roll, pitch, yaw as \(min, max, n\)$"),
    ]:
        with pytest.raises(parcal.Error, match=message):
            parcal.correction_table(str(calibration), **bad)
    cli("calibrate", paper, "--time-limit", 0, "--out", tmp_path / "late.json")
    with pytest.raises(parcal.Error, match="give accept_rejected=True to use it anyway"):
        parcal.correction_table(str(tmp_path / "late.rejected.json"), **axes)


def test_export_writes_a_hexapods_files_as_the_cli(paper, cli, tmp_path):
    calibration = tmp_path / "calibration.json"
    cli("calibrate", paper, "--out", calibration)
    run = parcal.calibrate(parcal.read_dataset(paper))
    for fmt in ("machine-json", "genhexkins", "summary"):
        out = tmp_path / fmt
        cli("export", "--calibration", calibration, "--format", fmt, "--out", out)
        exported = parcal.export(str(calibration), fmt)
        assert exported["text"] == out.read_text(), fmt
        assert exported["lost"] == [] and exported["cost"] is None and exported["print_radius"] is None
    # The calibrated machine.json is the design of the next calibration.
    assert json.loads(parcal.export(run, "machine-json")["text"])["format"] == "parcal-machine/1"
    assert "setp genhexkins." in parcal.export(run, "genhexkins")["text"]
    # Refusals name what is wrong.
    with pytest.raises(parcal.Error, match="a hexapod calibration; reprapfirmware exports a linear delta's"):
        parcal.export(run, "reprapfirmware")
    common = tmp_path / "common.json"
    cli("calibrate", paper, "--common", "--out", common)
    with pytest.raises(parcal.Error, match="a hexapod's calibration through the common path"):
        parcal.export(str(common), "genhexkins")
    with pytest.raises(parcal.Error, match="format: expected one of machine-json, genhexkins, summary, reprapfirmware"):
        parcal.export(run, "gcode")


def test_the_package_s_all_names_every_function_and_type_it_offers():
    # A function added to the package and left out of __all__ fails here;
    # `from parcal import *` gives the API, not the modules the package
    # itself imports (json, os, typing's names).
    public = {name for name in dir(parcal) if not name.startswith("_")}
    api = {name for name in public if callable(getattr(parcal, name)) and name[0].islower()}
    api |= {"Calibration", "Dataset", "Error", "MechanismCalibration", "MechanismDataset"}
    api -= {"overload"}
    assert set(parcal.__all__) == api | {"__version__"}
    namespace = {}
    exec("from parcal import *", namespace)
    assert {name for name in namespace if name != "__builtins__"} == set(parcal.__all__)
