"""parcal.simulate and parcal.validate against the parcal binary."""

import json
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
