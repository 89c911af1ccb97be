"""parcal on a linear delta and a cable robot (MechanismDataset) against
the parcal binary: reading, calibration, validation, compensation, plan."""

import csv
import json
import os
import shutil

import numpy as np
import pytest

import parcal
from conftest import ROOT


def fitted(record):
    """A calibration's record (a run, or calibration.json's text) but for
    the dataset it names, a directory or "(in memory)" (its checksum stays,
    the same for the same data), and the reasons' names of observations
    (by file and line, or in memory by kind and index)."""
    text = record if isinstance(record, str) else record.to_json()
    record = json.loads(text)
    record["provenance"].pop("dataset")
    record.pop("reasons")
    return record


@pytest.fixture
def hangprinter(tmp_path):
    """A copy of fixtures/hangprinter: a real cable robot's 44 encoder samples and 4 line lengths."""
    path = tmp_path / "hangprinter"
    shutil.copytree(ROOT / "fixtures" / "hangprinter", path)
    return path


def test_read_dataset_reads_the_kind_machine_json_declares(hangprinter):
    ds = parcal.read_dataset(hangprinter)
    assert isinstance(ds, parcal.MechanismDataset)
    assert isinstance(parcal.read_dataset(ROOT / "fixtures" / "paper-seed1"), parcal.Dataset)
    assert ds.mechanism == "cable robot"
    machine = json.loads((hangprinter / "machine.json").read_text())
    assert ds.parameters == list(machine["configured"])
    assert np.array_equal(ds.configured, list(machine["configured"].values()))
    assert ds.units == ["mm"] * 19 and ds.groups[0] == "anchors" and ds.groups[-1] == "encoder zero"
    assert np.array_equal(ds.prior_sigmas, [50.0] * 12 + [1.0] * 4 + [5.0] * 3)
    with open(hangprinter / "points.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    samples = ds.samples
    assert samples["readings"].shape == (len(rows), 4) and samples["loads"].shape == (len(rows), 4)
    assert np.array_equal(samples["readings"][1], [float(rows[1][f"q{i}"]) for i in range(1, 5)])
    assert np.array_equal(samples["measured"], [row["x"] != "" for row in rows])
    assert np.all(np.isnan(samples["position"][~samples["measured"]]))
    assert ds.quantities["quantity"] == [f"line_length_{c}" for c in "abcd"]
    assert ds.probes.shape == (0, 3) and ds.distances.shape == (0, 7) and ds.truth is None
    assert ds.machine == {"design": None, **machine}  # as written: no design, the configured values
    assert ds.print_radius is None  # a cable robot's machine.json states none
    # What the properties give, the constructor takes back; measured must
    # agree with the positions given.
    again = parcal.MechanismDataset(ds.machine, samples=ds.samples, quantities=ds.quantities)
    assert np.array_equal(again.samples["position"], samples["position"], equal_nan=True)
    assert np.array_equal(again.samples["measured"], samples["measured"])
    flipped = {**samples, "measured": ~samples["measured"]}
    first = "a position" if flipped["measured"][0] else "no position"
    with pytest.raises(parcal.Error, match=f"samples: row 0: measured says {first} was measured, position says otherwise"):
        parcal.MechanismDataset(ds.machine, samples=flipped)


@pytest.mark.parametrize(
    "options",
    [
        {"mechanism": "delta", "balls": 3, "plate": "all", "trackers": 2, "part_distances": 3, "manual_heights": 3},
        {"mechanism": "cable", "samples": 12, "known_positions": 4, "zero_loads": [14.0, 14.5, 13.5, 12.5]},
    ],
)
def test_what_a_mechanism_dataset_gives_its_constructor_takes_back(options):
    ds = parcal.simulate(4, **options)
    kinds = ("probes", "heights", "distances", "balls", "touches", "ball_distances", "tracker_points", "samples", "quantities")
    again = parcal.MechanismDataset(ds.machine, **{kind: getattr(ds, kind) for kind in kinds})
    for kind in kinds:
        given, taken = getattr(ds, kind), getattr(again, kind)
        pairs = [(given[k], taken[k]) for k in given] if isinstance(given, dict) else [(given, taken)]
        for a, b in pairs:
            assert (a is None and b is None) or np.array_equal(np.asarray(a), np.asarray(b), equal_nan=np.asarray(a).dtype.kind == "f"), kind
    assert again.machine == ds.machine


def test_a_mechanism_dataset_written_reads_back_the_same(delta, tmp_path):
    original = parcal.MechanismDataset.read(delta)
    original.write(tmp_path / "copy")
    copy = parcal.MechanismDataset.read(tmp_path / "copy")
    for name in ("probes", "distances", "configured", "design", "prior_sigmas"):
        assert np.array_equal(getattr(copy, name), getattr(original, name)), name
    assert copy.machine == original.machine and copy.trigger_height == {"value": 0.7, "sigma": 0.05}
    assert copy.print_radius == original.print_radius == 100.0  # the simulated printer's
    assert np.array_equal(copy.truth["parameters"], original.truth["parameters"])
    with pytest.raises(parcal.Error, match="copy"):
        original.write(tmp_path / "copy")


@pytest.mark.parametrize(
    "options, flags",
    [
        ({}, []),
        ({"snoop": True}, ["--snoop"]),
        ({"loss": "huber"}, ["--loss", "huber"]),
        ({"lm": True}, ["--lm"]),
    ],
)
def test_the_hangprinter_gives_the_calibration_json_of_the_cli(hangprinter, cli, tmp_path, options, flags):
    out = tmp_path / "cli.json"
    status = cli("calibrate", hangprinter, "--out", out, *flags)
    expected = (out if status == 0 else out.with_name("cli.rejected.json")).read_text()
    run = parcal.calibrate(parcal.read_dataset(hangprinter), **options)
    assert run.to_json() == expected
    record = json.loads(expected)
    assert run.to_dict() == record
    assert run.verdict == ("accepted" if record["accepted"] else "rejected")
    assert run.names == [p["name"] for p in record["parameters"]]
    assert np.array_equal(run.values, [p["value"] for p in record["parameters"]])
    assert np.array_equal(run.sigmas, [p["sigma"] for p in record["parameters"]])
    assert np.array_equal(run.covariance, record["covariance"])
    assert np.allclose(np.sqrt(np.diag(run.covariance)), run.sigmas, rtol=1e-12)
    tests = run.observations
    runs = record["tests"]["observations"]
    assert len(tests["kind"]) == sum(r.get("count", 1) for r in runs) == 48
    assert len(runs) < 48, "observations in sequence are written as runs"
    assert {"points.csv line 2 (point sample 0)", "quantities.csv line 5 (measured quantity 3)"} <= set(tests["place"])
    assert np.nanmax(np.abs(tests["normalised_residual"])) <= run.critical_value
    assert run.identifiability["statements"][: len(record["identifiability"]["statements"])] == \
        record["identifiability"]["statements"]
    run.write(tmp_path / "python.json")
    assert (tmp_path / "python.json").read_text() == expected


def test_a_mechanisms_progress_is_called_and_its_exception_stops_the_run(delta, paper, progress_check):
    for dataset, options in [(parcal.read_dataset(delta), {}),
                             (parcal.read_dataset(paper), {"common": True, "sim": "III"})]:
        run, seen = progress_check(lambda **progress: parcal.calibrate(dataset, **progress, **options),
                                   lambda run: run.iterations)
        assert seen[-1]["cost"] == run.to_dict()["global_test"]["cost"]
        run = parcal.calibrate(dataset, time_limit=0, **options)
        assert run.verdict == "rejected" and run.status == "TimeLimit"
        assert "it reached the time limit" in run.reasons[0]


def test_a_simulated_delta_recovers_its_truth_within_4_sigma(delta):
    ds = parcal.read_dataset(delta)
    run = parcal.calibrate(ds)
    assert run.verdict == "accepted", run.reasons
    truth = np.append(ds.truth["canonical"], ds.truth["trigger_height"])
    assert run.names == ds.parameters + ["trigger_height"]
    gauge = run.sigmas == 0.0
    # The canonical frame fixes the same values in the truth and the estimate.
    assert np.allclose(run.values[gauge], truth[gauge], atol=1e-9)
    # Identifiable: the data, not the prior, set the sigma (posterior under
    # half the prior). The truth is drawn from the prior and the probes'
    # noise is Gaussian, so each error is N(0, sigma): 4 sigma fails with
    # probability 6e-5 per parameter.
    identifiable = ~gauge & (run.sigma_ratios < 0.5)
    assert {"homed_height", "radius", "endstop_a", "angle_a"} <= {n for n, k in zip(run.names, identifiable) if k}
    errors = (run.values - truth)[identifiable] / run.sigmas[identifiable]
    assert np.all(np.abs(errors) < 4.0), dict(zip(np.array(run.names)[identifiable], errors))


def test_rods_cut_as_a_matched_set_correlate_their_priors_as_the_cli(delta, cli, tmp_path):
    matched = tmp_path / "matched"
    shutil.copytree(delta, matched)
    machine = json.loads((matched / "machine.json").read_text())
    machine["matched"] = {"diagonal rods": 0.02}
    (matched / "machine.json").write_text(json.dumps(machine))
    run = parcal.calibrate(parcal.read_dataset(matched))
    free = parcal.calibrate(parcal.read_dataset(delta))
    assert free.prior_correlation is None
    rods = [run.names.index(f"diagonal_{t}") for t in "abc"]
    sigma = machine["tolerances"]["diagonal rods"]
    for a in rods:
        for b in rods:
            expected = 1.0 if a == b else 1.0 - 0.02**2 / sigma**2
            assert abs(run.prior_correlation[a, b] - expected) < 1e-12
    # The rods' difference: at most sqrt(2) x 0.02 mm, far tighter than free.
    def spread(r):
        c = r.covariance
        return np.sqrt(c[rods[0], rods[0]] + c[rods[1], rods[1]] - 2 * c[rods[0], rods[1]])
    assert spread(run) <= np.sqrt(2) * 0.02 * (1 + 1e-9) < spread(free)
    out = tmp_path / "calibration.json"
    cli("calibrate", matched, "--out", out)
    recorded = json.loads(out.read_text())["prior_correlation"]
    assert np.array_equal(np.array(recorded), run.prior_correlation)


def held_out_hangprinter(hangprinter, path):
    """The 32 positions the author discarded, as a dataset (docs/cable-robots-validation.md)."""
    path.mkdir()
    shutil.copy(hangprinter / "machine.json", path)
    readings = np.loadtxt(hangprinter / "points.csv", delimiter=",", skiprows=1, usecols=range(4))
    untrusted = np.loadtxt(hangprinter / "untrusted.csv", delimiter=",", skiprows=1)
    rows = np.hstack([readings[untrusted[:, 0].astype(int)], untrusted[:, 1:]])
    np.savetxt(path / "points.csv", rows, delimiter=",", header="q1,q2,q3,q4,x,y,z", comments="", fmt="%.17g")
    return path


def test_validate_the_hangprinter_on_its_held_out_positions_as_the_cli(hangprinter, cli, tmp_path):
    held_out = held_out_hangprinter(hangprinter, tmp_path / "held-out")
    calibration = tmp_path / "calibration.json"
    cli("calibrate", hangprinter, "--out", calibration)
    cli("validate", held_out, "--calibration", calibration, "--out", tmp_path / "v.json")
    expected = json.loads((tmp_path / "v.json").read_text())
    del expected["format"]
    mine = parcal.validate(parcal.read_dataset(held_out), calibration=str(calibration))
    assert mine == expected
    # The author's judgement, in numbers (docs/cable-robots-validation.md).
    assert mine["verdict"] == "rejected"
    in_memory = parcal.calibrate(parcal.read_dataset(hangprinter))
    again = parcal.validate(parcal.read_dataset(held_out), calibration=in_memory)
    assert again == {**mine, "calibration": "(in memory)"}
    # Its own samples and line lengths, each fold by the others' calibration.
    cli("validate", hangprinter, "--folds", 4, "--out", tmp_path / "cv.json")
    expected = json.loads((tmp_path / "cv.json").read_text())
    del expected["format"]
    assert parcal.validate(parcal.read_dataset(hangprinter), folds=4) == expected
    assert expected["calibration"] == "4-fold cross-validation" and expected["verdict"] == "accepted"
    with pytest.raises(parcal.Error, match="give calibration or folds"):
        parcal.validate(parcal.read_dataset(hangprinter), calibration=in_memory, folds=4)


def split_probes(delta, path):
    """`delta` as two datasets: its even probe heights and part distances, and its odd probe heights."""
    fit, held_out = path / "fit", path / "held-out"
    for directory in (fit, held_out):
        directory.mkdir()
        shutil.copy(delta / "machine.json", directory)
    lines = (delta / "probes.csv").read_text().splitlines()
    (fit / "probes.csv").write_text("\n".join([lines[0], *lines[1::2]]) + "\n")
    (held_out / "probes.csv").write_text("\n".join([lines[0], *lines[2::2]]) + "\n")
    shutil.copy(delta / "distances.csv", fit)
    return fit, held_out


def test_a_delta_validates_on_held_out_probes(delta, tmp_path):
    fit, held_out = split_probes(delta, tmp_path)
    run = parcal.calibrate(parcal.read_dataset(fit))
    assert run.verdict == "accepted", run.reasons
    validation = parcal.validate(parcal.read_dataset(held_out), calibration=run)
    # The same machine measured again: the held-out residuals agree with
    # the noise and the calibration's covariance (a 5 % test, this seed).
    assert validation["verdict"] == "accepted", validation["reasons"]
    assert validation["test"]["degrees_of_freedom"] == len(validation["rows"]) == 16


def test_compensate_gives_the_commands_of_the_cli(delta, cli, tmp_path):
    calibration = tmp_path / "calibration.json"
    cli("calibrate", delta, "--out", calibration)
    targets = np.array([[0.0, 0.0, 5.0], [30.0, -20.0, 10.0], [-60.0, 45.0, 120.0]])
    np.savetxt(tmp_path / "t.csv", targets, delimiter=",", header="x,y,z", comments="", fmt="%.17g")
    cli("compensate", "--calibration", calibration, "--targets", tmp_path / "t.csv", "--out", tmp_path / "q.csv")
    theirs = np.loadtxt(tmp_path / "q.csv", delimiter=",", skiprows=1)
    mine = parcal.compensate(str(calibration), targets)
    assert np.array_equal(mine["target"], targets)
    assert np.array_equal(np.hstack([mine["target"], mine["q"], mine["nominal"]]), theirs)
    assert mine["sigma"].shape == (3, 3) and np.all(mine["sigma"] > 0)
    in_memory = parcal.compensate(parcal.MechanismCalibration.read(calibration), targets)
    assert np.array_equal(in_memory["q"], mine["q"])
    with pytest.raises(parcal.Error, match=r"1 of 2 targets cannot be reached by the calibrated linear delta:\n  target row 1: "):
        parcal.compensate(str(calibration), [[0.0, 0.0, 5.0], [0.0, 0.0, 5000.0]])
    # The calibration carries the printer's printable radius (100 mm, not the typical 110 mm).
    assert parcal.MechanismCalibration.read(calibration).print_radius == 100.0
    with pytest.raises(parcal.Error, match=r"target row 1: .*beyond the print radius 100"):
        parcal.compensate(str(calibration), [[0.0, 0.0, 5.0], [105.0, 0.0, 5.0]])


def test_plan_chooses_the_probes_of_the_cli(delta, cli, tmp_path):
    cli("plan", delta, "--measurements", 4, "--out", tmp_path / "next.csv")
    summary = json.loads((tmp_path / "next.json").read_text())
    plan = parcal.plan(parcal.read_dataset(delta), 4)
    assert plan["group"] == summary["group"] == "diagonal rods"
    assert plan["feasible"] == summary["feasible_candidates"]
    assert plan["kind"] == [m["kind"] for m in summary["measurements"]]
    assert np.array_equal(plan["position"], [m["target"] for m in summary["measurements"]])
    assert np.array_equal(plan["trace"], [m["trace_after"] for m in summary["measurements"]])
    assert np.all(np.diff(np.append(plan["trace_before"], plan["trace"])) <= 0)
    after = parcal.plan(parcal.read_dataset(delta), 4, after=parcal.calibrate(parcal.read_dataset(delta)))
    assert after["from_calibration"] and after["trace_before"] < plan["trace_before"]
    with pytest.raises(parcal.Error, match="measured_positions applies to a cable robot"):
        parcal.plan(parcal.read_dataset(delta), 4, measured_positions=True)
    with pytest.raises(parcal.Error, match="measurements"):
        parcal.plan(parcal.read_dataset(delta), 0)


def test_plan_chooses_the_heights_and_distances_of_the_cli(delta, cli, tmp_path):
    # Probe heights, then heights measured by hand on a 10 mm gauge, then part distances.
    cli("plan", delta, "--measurements", 3, "--heights", 2, "--height-sigma", 0.02, "--gauge", 10,
        "--distances", 2, "--out", tmp_path / "next.csv")
    summary = json.loads((tmp_path / "next.json").read_text())
    dataset = parcal.read_dataset(delta)
    plan = parcal.plan(dataset, 3, heights=2, height_sigma=0.02, gauge=10, distances=2)
    measurements = summary["measurements"]
    assert plan["kind"] == [m["kind"] for m in measurements]
    assert plan["kind"] == ["probe height"] * 3 + ["manual height"] * 2 + ["part distance"] * 2
    assert np.array_equal(plan["position"][:5], [m["target"] for m in measurements[:5]])
    assert np.all(plan["position"][3:5, 2] == 10.0)
    assert np.array_equal(plan["position"][5:], [m["ends"][0] for m in measurements[5:]])
    assert np.array_equal(plan["end"][5:], [m["ends"][1] for m in measurements[5:]])
    assert np.all(np.isnan(plan["end"][:5]))
    assert np.array_equal(plan["trace"], [m["trace_after"] for m in measurements])
    # Heights alone after a calibration, minimising the trigger height's variance.
    after = parcal.plan(dataset, heights=2, height_sigma=0.02, after=parcal.calibrate(dataset))
    assert after["kind"] == ["manual height"] * 2 and after["group"] == "trigger height"
    trigger = after["parameters"]["name"].index("trigger_height")
    assert after["parameters"]["after"][trigger] < after["parameters"]["before"][trigger]
    with pytest.raises(parcal.Error, match="noise.height"):
        parcal.plan(dataset, heights=2)
    with pytest.raises(parcal.Error, match=r"height_sigma must be in \(0, 1\] mm, got NaN"):
        parcal.plan(dataset, heights=2, height_sigma=float("nan"))
    with pytest.raises(parcal.Error, match=r"gauge must be in \(0, 100\] mm, got 500"):
        parcal.plan(dataset, heights=2, height_sigma=0.02, gauge=500)


def test_bad_input_raises_parcal_error_naming_the_file_and_line(delta, hangprinter, tmp_path):
    bad = tmp_path / "bad"
    shutil.copytree(delta, bad)
    lines = (bad / "probes.csv").read_text().splitlines()
    lines[3] = "10,20,nan"
    (bad / "probes.csv").write_text("\n".join(lines) + "\n")
    with pytest.raises(parcal.Error, match=r"probes\.csv.*line 4"):
        parcal.read_dataset(bad)
    with pytest.raises(parcal.Error, match=r"points\.csv"):
        (hangprinter / "points.csv").write_text("q1,q2,q3\n1,2,3\n")
        parcal.read_dataset(hangprinter)
    ds = parcal.read_dataset(delta)
    distances = ds.distances.copy()
    distances[1, 6] = -distances[1, 6]
    with pytest.raises(parcal.Error, match=r"distances\.csv: field row 1, column distance: must be positive"):
        parcal.MechanismDataset(ds.machine, probes=ds.probes, distances=distances)
    with pytest.raises(parcal.Error, match="time_limit: -1"):
        parcal.calibrate(ds, time_limit=-1)
    with pytest.raises(parcal.Error, match="loss: "):
        parcal.calibrate(ds, loss="quartic")
    with pytest.raises(parcal.Error, match="options.snoop: data snooping with a robust loss"):
        parcal.calibrate(ds, snoop=True, loss="huber")
    with pytest.raises(parcal.Error, match="max_iterations"):
        parcal.calibrate(ds, max_iterations=0)
    with pytest.raises(TypeError, match="sim"):
        parcal.calibrate(ds, sim="III")
    with pytest.raises(parcal.Error, match=r"targets: expected 3 columns, got 6"):
        parcal.compensate(parcal.calibrate(ds), np.zeros((2, 6)))
    with pytest.raises(parcal.Error, match=r"targets"):
        parcal.compensate(parcal.calibrate(ds), np.zeros((0, 3)))
    paper = parcal.calibrate(parcal.read_dataset(ROOT / "fixtures" / "paper-seed1"))
    paper.write(tmp_path / "hexapod.json")
    with pytest.raises(parcal.Error, match="hexapod.json"):
        parcal.validate(ds, calibration=str(tmp_path / "hexapod.json"))


def test_a_dataset_built_in_memory_calibrates_as_its_files(hangprinter, delta):
    machine = json.loads((hangprinter / "machine.json").read_text())
    points = np.genfromtxt(hangprinter / "points.csv", delimiter=",", skip_header=1)
    with open(hangprinter / "quantities.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    quantities = {"quantity": [r["quantity"] for r in rows], "value": [float(r["value"]) for r in rows],
                  "sigma": [float(r["sigma"]) for r in rows]}
    samples = {"readings": points[:, :4], "position": points[:, 4:7], "loads": points[:, 7:]}
    built = parcal.MechanismDataset(machine, samples=samples, quantities=quantities)
    from_files = parcal.read_dataset(hangprinter)
    assert np.array_equal(built.samples["measured"], from_files.samples["measured"])
    run, run_of_files = parcal.calibrate(built), parcal.calibrate(from_files)
    assert fitted(run) == fitted(run_of_files)
    # The reasons name the largest w-test's sample by its line in the files,
    # by its index in memory.
    by_line = [r for r in run_of_files.reasons if "w-test" in r]
    assert len(by_line) == 1 and "points.csv line " in by_line[0], run_of_files.reasons
    by_index = [r for r in run.reasons if "w-test" in r]
    assert len(by_index) == 1 and "points.csv" not in by_index[0], run.reasons
    # A sample given twice is warned of, by its index in memory.
    copied = {key: np.vstack([rows, rows[5:6]]) for key, rows in samples.items()}
    twice = parcal.calibrate(parcal.MechanismDataset(machine, samples=copied, quantities=quantities))
    assert run.warnings == [] and len(twice.warnings) == 1, twice.warnings
    assert twice.warnings[0].startswith("point sample 44 repeats point sample 5 in every number")
    assert twice.to_dict()["warnings"] == twice.warnings
    # numpy's numbers in the machine's dict read as Python's; a number that
    # is not finite is named by its keys.
    as_numpy = {**machine, "configured": {k: np.float64(v) for k, v in machine["configured"].items()}}
    as_numpy["configured"]["radius_a"] = np.array(75.0)
    assert parcal.MechanismDataset(as_numpy, samples=samples, quantities=quantities).machine == built.machine
    as_numpy["configured"]["radius_b"] = float("nan")
    with pytest.raises(parcal.Error, match=r"machine.json: configured.radius_b: not a finite number"):
        parcal.MechanismDataset(as_numpy, samples=samples, quantities=quantities)
    delta_machine = json.loads((delta / "machine.json").read_text())
    probes = np.loadtxt(delta / "probes.csv", delimiter=",", skiprows=1)
    probes[3, 2] = np.inf
    with pytest.raises(parcal.Error, match=r"\(in memory\)/probes\.csv: field row 3, column z: value inf is not a finite number"):
        parcal.MechanismDataset(delta_machine, probes=probes)
    with pytest.raises(parcal.Error, match=r"noise\.distance: required"):
        parcal.MechanismDataset({**delta_machine, "noise": {"probe": 0.01}}, distances=np.ones((2, 7)))
    with pytest.raises(parcal.Error, match=r"samples\[\"readings\"\]: expected 4 columns, got 3"):
        parcal.MechanismDataset(machine, samples={"readings": np.ones((2, 3))})
    # A misspelt key is refused, not passed over (the loads would be lost).
    with pytest.raises(parcal.Error, match=r'samples: unknown key "load" \(its keys are readings, position, measured, loads\)'):
        parcal.MechanismDataset(machine, samples={"readings": np.ones((2, 4)), "load": np.ones((2, 4))})
    with pytest.raises(parcal.Error, match=r"machine\.json: .*unknown mechanism"):
        parcal.MechanismDataset({**machine, "mechanism": "scara"}, probes=probes)


def test_elastic_lines_in_a_machine_dict_calibrate_and_compensate_as_the_cli(hangprinter, delta, cli, tmp_path):
    machine = json.loads((hangprinter / "machine.json").read_text())
    points = np.genfromtxt(hangprinter / "points.csv", delimiter=",", skip_header=1)
    machine["configured"]["compliance_abcd"] = 50.0
    machine["elasticity"] = {"compliance_of_line": [0, 0, 0, 0], "zero_loads": list(points[0, 7:])}
    (hangprinter / "machine.json").write_text(json.dumps(machine))
    out = tmp_path / "calibration.json"
    assert cli("calibrate", hangprinter, "--out", out) == 0
    built = parcal.MechanismDataset(
        machine, samples={"readings": points[:, :4], "position": points[:, 4:7], "loads": points[:, 7:]})
    assert built.parameters[-1] == "compliance_abcd"
    assert built.machine["elasticity"] == machine["elasticity"]
    run = parcal.calibrate(parcal.read_dataset(hangprinter))
    record = json.loads(run.to_json())
    assert record["elasticity"] == machine["elasticity"]
    cli_record = json.loads(out.read_text())
    assert [p["value"] for p in record["parameters"]] == [p["value"] for p in cli_record["parameters"]]
    # Commands under the lines' loads, as the CLI's from a targets file with f1..f4.
    targets, loads = np.array([[0.0, 0.0, 100.0], [50.0, -20.0, 300.0]]), np.array([[30.0] * 4, [10.0, 20.0, 30.0, 25.0]])
    (tmp_path / "targets.csv").write_text(
        "x,y,z,f1,f2,f3,f4\n" + "".join(",".join(map(str, [*t.tolist(), *f.tolist()])) + "\n" for t, f in zip(targets, loads)))
    assert cli("compensate", "--calibration", out, "--targets", tmp_path / "targets.csv", "--out", tmp_path / "q.csv") == 0
    from_cli = np.genfromtxt(tmp_path / "q.csv", delimiter=",", skip_header=1)
    commands = parcal.compensate(out, targets, loads=loads)
    np.testing.assert_allclose(commands["q"], from_cli[:, 7:11], rtol=1e-12)
    assert not np.allclose(commands["q"], parcal.compensate(out, targets)["q"], rtol=1e-9)
    with pytest.raises(parcal.Error, match=r"loads has 1 rows and targets 2"):
        parcal.compensate(out, targets, loads=loads[:1])
    with pytest.raises(parcal.Error, match=r"loads: the linear delta's readings do not depend"):
        parcal.compensate(parcal.calibrate(parcal.read_dataset(delta)), targets, loads=loads, accept_rejected=True)
    with pytest.raises(parcal.Error, match=r"elasticity: the loads at the encoder zero lists 3 values for 4 lines"):
        parcal.MechanismDataset({**machine, "elasticity": {"compliance_of_line": [0] * 4, "zero_loads": [1.0] * 3}},
                                samples={"readings": points[:, :4]})


def test_a_cable_robot_plans_measured_samples_as_the_cli(hangprinter, cli, tmp_path):
    cli("plan", hangprinter, "--measurements", 3, "--measured-positions", "--grid", 6, "--out", tmp_path / "next.csv")
    summary = json.loads((tmp_path / "next.json").read_text())
    plan = parcal.plan(parcal.read_dataset(hangprinter), 3, measured_positions=True, grid=6)
    assert plan["group"] == "anchors" and plan["kind"] == ["point sample"] * 3
    assert np.array_equal(plan["position"], [m["target"] for m in summary["measurements"]])
    assert np.array_equal(plan["trace"], [m["trace_after"] for m in summary["measurements"]])
    assert plan["parameters"]["name"][:12] == parcal.read_dataset(hangprinter).parameters[:12]
    assert np.all(plan["parameters"]["after"] <= plan["parameters"]["before"])


def test_a_rejected_calibration_is_applied_only_when_accepted_anyway(hangprinter, tmp_path):
    # The discarded positions, calibrated as if trusted: rejected.
    held_out = held_out_hangprinter(hangprinter, tmp_path / "held-out")
    (held_out / "quantities.csv").write_text((hangprinter / "quantities.csv").read_text())
    run = parcal.calibrate(parcal.read_dataset(held_out))
    assert run.verdict == "rejected", run.reasons
    targets = [[0.0, 0.0, 300.0]]
    with pytest.raises(parcal.Error, match=r"\(in memory\): the calibration was rejected .*accept_rejected=True"):
        parcal.compensate(run, targets)
    assert parcal.compensate(run, targets, accept_rejected=True)["q"].shape == (1, 4)
    with pytest.raises(parcal.Error, match="plan after an accepted one"):
        parcal.plan(parcal.read_dataset(hangprinter), 3, after=run)


def test_a_delta_touching_balls_built_in_memory_calibrates_as_its_files(cli, tmp_path):
    cli("simulate", "--mechanism", "delta", "--seed", 3, "--balls", 3, "--points-per-ball", 7, "--out", tmp_path / "sim")
    from_files = parcal.read_dataset(tmp_path / "sim")
    assert from_files.balls.shape == (3, 2) and from_files.touches.shape == (21, 4)
    machine = json.loads((tmp_path / "sim" / "machine.json").read_text())
    built = parcal.MechanismDataset(machine, probes=from_files.probes, distances=from_files.distances,
                                    balls=from_files.balls, touches=from_files.touches)
    assert np.array_equal(built.balls, from_files.balls) and np.array_equal(built.touches, from_files.touches)
    assert fitted(parcal.calibrate(built)) == fitted(parcal.calibrate(from_files))
    # The touches by their coordinates (eq. 10), weighted 1/sigma without an
    # angle prior: the same minimum as by their radius rows, each within
    # 1e-3 of its sigma of it, three rows a touch.
    by_radius = parcal.calibrate(built)
    by_coordinates = parcal.calibrate(built, observation="coordinates")
    assert np.all(np.abs(by_coordinates.values - by_radius.values) <= 2e-3 * by_radius.sigmas)
    rows = lambda run: run.to_dict()["tests"]["data_rows"]
    assert rows(by_coordinates) == rows(by_radius) + 2 * 21
    with pytest.raises(parcal.Error, match=r'observation: "angles" is not one of radius, coordinates'):
        parcal.calibrate(built, observation="angles")
    touches = from_files.touches.copy()
    touches[2, 0] = 0.5
    with pytest.raises(parcal.Error, match=r"touches row 2: ball 0\.5 is not a ball's number"):
        parcal.MechanismDataset(machine, probes=from_files.probes, balls=from_files.balls, touches=touches)
    touches[2, 0] = 1e300
    with pytest.raises(parcal.Error, match=r"touches row 2: ball 1e300 is not a ball's number"):
        parcal.MechanismDataset(machine, probes=from_files.probes, balls=from_files.balls, touches=touches)


def test_a_delta_measured_by_trackers_in_memory_calibrates_as_its_files(cli, tmp_path):
    cli("simulate", "--mechanism", "delta", "--seed", 3, "--trackers", 2, "--points-per-tracker", 10,
        "--out", tmp_path / "sim")
    from_files = parcal.read_dataset(tmp_path / "sim")
    points = from_files.tracker_points
    assert points["tracker"][:2] == ["T1", "T1"] and points["measured"].shape == (20, 3)
    machine = json.loads((tmp_path / "sim" / "machine.json").read_text())
    built = parcal.MechanismDataset(machine, probes=from_files.probes, tracker_points=points)
    run = parcal.calibrate(built)
    assert fitted(run) == fitted(parcal.calibrate(from_files))
    cli("calibrate", tmp_path / "sim", "--out", tmp_path / "calibration.json")
    assert fitted(run) == fitted((tmp_path / "calibration.json").read_text())
    assert [t["label"] for t in run.trackers] == ["T1", "T2"] and len(run.trackers[0]["sigma"]) == 6
    with pytest.raises(parcal.Error, match=r"tracker_points: tracker, commanded and measured have 2, 20 and 20 rows"):
        parcal.MechanismDataset(machine, probes=from_files.probes,
                                tracker_points={**points, "tracker": ["T1", "T2"]})


def test_a_ball_plate_ties_a_deltas_balls_in_memory_as_in_its_files(cli, tmp_path):
    cli("simulate", "--mechanism", "delta", "--seed", 3, "--balls", 3, "--points-per-ball", 7,
        "--plate", "all", "--plate-sigma", 2, "--out", tmp_path / "sim")
    from_files = parcal.read_dataset(tmp_path / "sim")
    mine = parcal.simulate(3, mechanism="delta", balls=3, points_per_ball=7, plate="all", plate_sigma=2)
    assert np.array_equal(mine.ball_distances, from_files.ball_distances)
    assert from_files.ball_distances.shape == (3, 4)
    assert np.array_equal(from_files.ball_distances[:, :2], [[0, 1], [0, 2], [1, 2]])
    assert np.all(from_files.ball_distances[:, 3] == 0.002)
    machine = json.loads((tmp_path / "sim" / "machine.json").read_text())
    built = parcal.MechanismDataset(machine, probes=from_files.probes, balls=from_files.balls,
                                    touches=from_files.touches, ball_distances=from_files.ball_distances)
    run = parcal.calibrate(built)
    assert fitted(run) == fitted(parcal.calibrate(from_files))
    assert run.verdict == "accepted", run.reasons
    places = [p for p, kind in zip(run.observations["place"], run.observations["kind"]) if kind == "ball distance"]
    assert places == [f"ball_distances.csv line {k + 2} (ball distance {k})" for k in range(3)]
    # The same balls measured again, held out: judged together with their distances.
    held_out = parcal.simulate(7, mechanism="delta", balls=3, points_per_ball=7, plate="all", plate_sigma=2,
                               probe_rings=1, truth=from_files)
    validation = parcal.validate(held_out, calibration=run)
    tied = [row for row in validation["rows"] if row["kind"] == "tied balls"]
    assert len(tied) == 3 * 7 + 3 - 9, validation["rows"]
    distances = from_files.ball_distances.copy()
    distances[1, 1] = 0
    with pytest.raises(parcal.Error, match=r"ball_distances\.csv: field row 1: balls 0 and 0 are not two distinct balls"):
        parcal.MechanismDataset(machine, probes=from_files.probes, balls=from_files.balls,
                                touches=from_files.touches, ball_distances=distances)
    with pytest.raises(parcal.Error, match="plate_sigma needs plate"):
        parcal.simulate(3, mechanism="delta", balls=3, plate_sigma=2)


def test_balls_placed_in_memory_are_the_placements_of_balls_csv(cli, tmp_path):
    cli("simulate", "--mechanism", "delta", "--seed", 3, "--balls", 3, "--points-per-ball", 7, "--out", tmp_path / "sim")
    ds = parcal.read_dataset(tmp_path / "sim")
    machine = json.loads((tmp_path / "sim" / "machine.json").read_text())
    # Ball 0 placed within 0.01 mm of where the fit without placements puts it;
    # the others not placed.
    free = parcal.calibrate(ds).to_dict()
    balls = np.full((3, 6), np.nan)
    balls[:, :2] = ds.balls
    balls[0, 2:] = [*free["balls"][0]["centre"], 0.01]
    placed = parcal.MechanismDataset(machine, probes=ds.probes, distances=ds.distances, balls=balls, touches=ds.touches)
    assert np.array_equal(placed.balls, balls, equal_nan=True)
    placed.write(tmp_path / "placed")
    header = (tmp_path / "placed" / "balls.csv").read_text().splitlines()[0]
    assert header.endswith("x,y,z,centre_sigma"), header
    from_files = parcal.read_dataset(tmp_path / "placed")
    assert np.array_equal(from_files.balls, balls, equal_nan=True)
    run = parcal.calibrate(placed)
    assert fitted(run) == fitted(parcal.calibrate(from_files))
    held, loose = run.to_dict()["balls"][0]["centre_sigma"], free["balls"][0]["centre_sigma"]
    assert max(held) <= 0.01 < 0.1 < max(loose), (held, loose)
    half = balls.copy()
    half[1, 2:] = [0.0, 0.0, np.nan, 0.01]
    with pytest.raises(parcal.Error, match=r"balls row 1: a placement gives all of x, y, z and centre_sigma, or none"):
        parcal.MechanismDataset(machine, probes=ds.probes, balls=half, touches=ds.touches)
    with pytest.raises(parcal.Error, match=r"balls: expected 2 or 6 columns, got 3"):
        parcal.MechanismDataset(machine, probes=ds.probes, balls=balls[:, :3], touches=ds.touches)


def test_a_hexapod_through_the_common_calibration_gives_the_calibration_json_of_the_cli(paper, cli, tmp_path):
    out = tmp_path / "cli.json"
    status = cli("calibrate", paper, "--common", "--sim", "III", "--out", out)
    expected = (out if status == 0 else out.with_name("cli.rejected.json")).read_text()
    run = parcal.calibrate(parcal.read_dataset(paper), common=True, sim="III")
    assert isinstance(run, parcal.MechanismCalibration)
    assert run.mechanism == "hexapod"
    assert run.to_json() == expected
    own = parcal.calibrate(parcal.read_dataset(paper), sim="III")
    # Each run stops within 1e-3 of its sigmas from the same minimum.
    assert np.all(np.abs(run.values - own.values) < 2e-3 * run.sigmas)
    # Its touches are placed in the hexapod dataset's measurements.csv.
    assert run.observations["place"][0] == "measurements.csv line 2 (ball touch 0)"
    # Judged on another campaign of the same machine (other noise).
    cli("simulate", "--seed", 7, "--out", tmp_path / "seed7")
    validation = parcal.validate(parcal.read_dataset(tmp_path / "seed7"), calibration=run, accept_rejected=True)
    assert validation["mechanism"] == "hexapod"
    assert len(validation["rows"]) == 27 * 4 and validation["rows"][0]["file"] == "artefacts.json"
    # Each ball's centre located by its first 4 touches, its other 3 predicted.
    referenced = parcal.validate(parcal.read_dataset(tmp_path / "seed7"), calibration=run, reference=4,
                                 accept_rejected=True)
    assert referenced["reference"] == 4 and len(referenced["rows"]) == 27 * 3
    # Each row a touch's, by its line: ball 0's fifth touch is line 6.
    first = referenced["rows"][0]
    assert (first["file"], first["kind"], first["line"]) == ("measurements.csv", "ball touch", 6)
    with pytest.raises(parcal.Error, match="reference 0: must be a whole number from 1"):
        parcal.validate(parcal.read_dataset(tmp_path / "seed7"), calibration=run, reference=0)
    # Applied as any mechanism's: targets in its six pose coordinates.
    out = parcal.compensate(run, [[-80.0, -30.0, 330.0, 0.05, 0.0, 0.0]])
    assert out["target"].shape == (1, 6) and out["sigma"].shape == (1, 6)
    assert out["q"].shape == (1, 6) and np.all(out["q"] != out["nominal"])
    with pytest.raises(parcal.Error, match="targets: expected 6 columns"):
        parcal.compensate(run, [[0.0, 0.0, 400.0]])
    # The default options: the coordinate observation (eq. 10), three rows
    # and two contact angles a touch, through the interface as in the own
    # calibration.
    run = parcal.calibrate(parcal.read_dataset(paper), common=True)
    own = parcal.calibrate(parcal.read_dataset(paper))
    assert np.all(np.abs(run.values - own.values) < 2e-3 * run.sigmas)
    assert run.to_dict()["tests"]["data_rows"] == 3 * 189
    # What takes a hexapod's own calibration says so of this one.
    with pytest.raises(parcal.Error, match=r"a parcal\.MechanismCalibration .*common=True"):
        parcal.accuracy(parcal.read_dataset(paper), run)


def test_unknown_scales_through_the_common_calibration(cli, tmp_path):
    # Touches read in motor revolutions with the scales unknowns (2 % prior):
    # the common calibration estimates them after the 33, in mm/rev, where the
    # own calibration does, within 2e-3 of their sigma.
    data = tmp_path / "rev"
    cli("simulate", "--seed", 3, "--readings", "rev", "--out", data)
    ds = parcal.read_dataset(data)
    run = parcal.calibrate(ds, common=True, sim="III", prior="propagated")
    assert run.names[33:] == [f"s_{i}" for i in range(1, 7)]
    assert run.units[33:] == ["mm/rev"] * 6
    own = parcal.calibrate(ds, sim="III", prior="propagated").to_dict()
    scales = np.array(own["machine"]["actuator"]["scale"])
    assert np.all(np.abs(run.values[33:] - scales) < 2e-3 * run.sigmas[33:])



def test_motion_capture_poses_through_the_common_calibration(tmp_path, cli):
    # fixtures/jugglebot's poses: one tracker and the body frame, as the CLI
    # writes them.
    path = tmp_path / "jugglebot"
    shutil.copytree(ROOT / "fixtures" / "jugglebot", path)
    out = tmp_path / "cli.json"
    assert cli("calibrate", path, "--common", "--out", out) == 0
    run = parcal.calibrate(parcal.read_dataset(path), common=True)
    assert run.to_json() == out.read_text()
    assert len(run.trackers) == 1 and "body" not in run.trackers[0]
    assert set(run.body) == {"frame", "sigma"} and all(s > 0 for s in run.body["sigma"])
    # Without a prior the tool keeps its tolerance, which holds it at the
    # design: no pose sees it.
    bare = parcal.calibrate(parcal.read_dataset(path), common=True, sim="I")
    design = json.loads(bare.to_json())["parameters"]
    for k, name in enumerate(bare.names):
        if name.endswith("_eT"):
            assert bare.values[k] == design[k]["prior_mean"]
            assert bare.sigmas[k] == pytest.approx(design[k]["prior_sigma"], rel=1e-9)


def test_export_writes_the_firmware_lines_of_the_cli(delta, hangprinter, cli, tmp_path):
    calibration = tmp_path / "calibration.json"
    cli("calibrate", delta, "--out", calibration)
    for firmware in ("reprapfirmware", "klipper", "marlin"):
        out = tmp_path / f"{firmware}.txt"
        cli("export", "--calibration", calibration, "--format", firmware, "--out", out)
        mine = parcal.export(str(calibration), firmware)
        assert mine["text"] == out.read_text()
        assert mine["print_radius"] == 100.0  # the simulated printer's, carried by its calibration
        comment = {"reprapfirmware": ";", "klipper": "#", "marlin": ";"}[firmware]
        assert f"{comment} parcal: cost: {mine['cost_sentence']}\n" in mine["text"]
        cost = mine["cost"]
        assert 0 <= cost["flatness_rms"] <= cost["flatness_max"] and 0 <= cost["volume_rms"] <= cost["volume_max"]
    # Marlin holds no bed tilt: what is lost is said; its lines end saving them.
    assert any("bed tilt" in sentence for sentence in mine["lost"])
    assert mine["text"].endswith("M500\n") and "\nM665 L" in mine["text"]
    # Probe heights alone leave the trigger height at its prior: kept, said why.
    assert mine["trigger_height"] is None and mine["trigger_sentence"].startswith("kept: ")
    assert f"; parcal: {mine['trigger_sentence']}\n" in mine["text"]
    # Heights measured by hand determine it: written, as the command writes it.
    heights = tmp_path / "heights"
    cli("simulate", "--mechanism", "delta", "--seed", 5, "--manual-heights", 5, "--height-sigma", 0.02, "--out", heights)
    determined = tmp_path / "determined.json"
    cli("calibrate", heights, "--out", determined)
    out = tmp_path / "determined.g"
    cli("export", "--calibration", determined, "--format", "reprapfirmware", "--out", out)
    written = parcal.export(str(determined), "reprapfirmware")
    assert written["text"] == out.read_text() and written["trigger_sentence"].startswith("written: ")
    trigger = parcal.MechanismCalibration.read(determined)
    value = trigger.values[trigger.names.index("trigger_height")]
    assert written["trigger_height"] == round(value, 3) and f"\nG31 Z{value:.3f}\n" in written["text"]
    marlin = parcal.export(str(determined), "marlin")
    out = tmp_path / "determined.gcode"
    cli("export", "--calibration", determined, "--format", "marlin", "--out", out)
    assert marlin["text"] == out.read_text() and f"\nM851 Z{-value:.3f}\nM500\n" in marlin["text"]
    # Lines for a Marlin compiled with radius trims, as the command writes them.
    out = tmp_path / "trimmed.gcode"
    cli("export", "--calibration", calibration, "--format", "marlin", "--radius-trims", "0.5,-0.25,0", "--out", out)
    trimmed = parcal.export(str(calibration), "marlin", radius_trims=(0.5, -0.25, 0.0))
    assert trimmed["text"] == out.read_text() and trimmed["radius_trims"] == [0.5, -0.25, 0.0]
    assert "; for a Marlin compiled with DELTA_RADIUS_TRIM_TOWER { 0.5, -0.25, 0 }\n" in trimmed["text"]
    assert parcal.export(str(calibration), "marlin")["radius_trims"] == [0.0, 0.0, 0.0]
    assert parcal.export(str(calibration), "klipper")["radius_trims"] is None
    with pytest.raises(parcal.Error, match="radius_trims: radius trims are Marlin's"):
        parcal.export(str(calibration), "klipper", radius_trims=(0.5, 0.0, 0.0))
    given = parcal.export(parcal.MechanismCalibration.read(calibration), "reprapfirmware", print_radius=90.0)
    assert given["print_radius"] == 90.0 and " B90.0 " in given["text"]
    with pytest.raises(parcal.Error, match="format: expected one of machine-json, genhexkins, summary, reprapfirmware, klipper, marlin, hangprinter, got \"smoothieware\""):
        parcal.export(str(calibration), "smoothieware")
    with pytest.raises(parcal.Error, match="a linear delta calibration; hangprinter exports a cable robot's"):
        parcal.export(str(calibration), "hangprinter")
    with pytest.raises(parcal.Error, match="print_radius must be a positive number of mm"):
        parcal.export(str(calibration), "klipper", print_radius=-1.0)
    # Into a printer.cfg: the whole file, as the command writes it.
    printer_cfg = tmp_path / "printer.cfg"
    printer_cfg.write_text("[printer]\nkinematics: delta\ndelta_radius: 135\n\n[stepper_a]\narm_length: 270\nposition_endstop: 300\n")
    out = tmp_path / "new.cfg"
    cli("export", "--calibration", calibration, "--format", "klipper", "--config", printer_cfg, "--out", out)
    into = parcal.export(str(calibration), "klipper", config=printer_cfg)
    assert into["text"] == out.read_text() and into["text"].startswith(printer_cfg.read_text())
    with pytest.raises(parcal.Error, match="config: reprapfirmware's lines are written alone"):
        parcal.export(str(calibration), "reprapfirmware", config=printer_cfg)

    robot = tmp_path / "robot.json"
    cli("calibrate", hangprinter, "--out", robot)
    out = tmp_path / "hangprinter.g"
    cli("export", "--calibration", robot, "--format", "hangprinter", "--out", out)
    lines = parcal.export(str(robot), "hangprinter")
    assert lines["text"] == out.read_text() and "\nM669 K6 A" in lines["text"]
    assert lines["lost"] == [] and lines["cost"] is None and lines["print_radius"] is None


def test_export_machine_json_of_a_mechanism_is_the_clis(hangprinter, cli, tmp_path):
    robot = tmp_path / "robot.json"
    cli("calibrate", hangprinter, "--out", robot)
    out = tmp_path / "machine.json"
    cli("export", "--calibration", robot, "--format", "machine-json", "--out", out)
    # The machine.json of the dataset the calibration names, or the one given.
    mine = parcal.export(str(robot), "machine-json")
    assert mine["text"] == out.read_text()
    given = parcal.export(str(robot), "machine-json", machine=hangprinter / "machine.json")
    assert given["text"] == mine["text"] and given["lost"] == [] and given["cost"] is None
    # A calibration made in memory names no dataset: its machine is given,
    # as a path or as the dataset's machine.json content.
    ds = parcal.read_dataset(hangprinter)
    run = parcal.calibrate(parcal.MechanismDataset(ds.machine, samples=ds.samples, quantities=ds.quantities))
    with pytest.raises(parcal.Error, match="it names no dataset \\(one built in memory\\): give the machine.json it was calibrated from \\(machine=\\)"):
        parcal.export(run, "machine-json")
    assert parcal.export(run, "machine-json", machine=ds.machine)["text"] == mine["text"]
    machine, record = json.loads(mine["text"]), json.loads(robot.read_text())
    assert machine["design"] == {p["name"]: p["value"] for p in record["parameters"]}
    assert machine["configured"] == json.loads((hangprinter / "machine.json").read_text())["configured"]
    sim = tmp_path / "sim"
    parcal.simulate(5, mechanism="delta").write(sim)
    with pytest.raises(parcal.Error, match="mechanism: the calibration is a cable robot's, machine.json a linear delta's"):
        parcal.export(str(robot), "machine-json", machine=sim / "machine.json")
    with pytest.raises(parcal.Error, match="machine: a mechanism's machine.json is what \"machine-json\" starts from"):
        parcal.export(str(robot), "hangprinter", machine=hangprinter / "machine.json")


CONFIG_G = "; config.g of a kit delta\nM665 L270 R135 H300 B100\nM666 X0 Y0 Z0\nG31 P500 X0 Y0 Z0.7\n"


def test_import_firmware_makes_the_datasets_of_the_cli(cli, tmp_path):
    sim = tmp_path / "sim"
    parcal.simulate(5, mechanism="delta", part_distances=3).write(sim)
    probes, distances = sim / "probes.csv", sim / "distances.csv"
    config = tmp_path / "config.g"
    config.write_text(CONFIG_G)
    heights = tmp_path / "heights.csv"
    heights.write_text("x,y,z,height\n0,0,5,5.12\n40,-20,2,1.97\n")
    out = tmp_path / "cli"
    cli("import", "reprapfirmware", "--config", config, "--probes", probes, "--distances", distances,
        "--heights", heights, "--height-sigma", "0.03",
        "--diagonal-tolerance", "0.3", "--matched-rods", "0.05", "--trigger-sigma", "0.02", "--out", out)
    ds = parcal.import_firmware("reprapfirmware", config, probes=probes, distances=distances, heights=heights,
                                height_sigma=0.03, diagonal_tolerance=0.3, matched_rods=0.05, trigger_sigma=0.02)
    mine = tmp_path / "mine"
    ds.write(mine)
    assert sorted(os.listdir(mine)) == sorted(os.listdir(out)) == [
        "distances.csv", "heights.csv", "machine.json", "probes.csv"]
    assert ds.heights.tolist() == [[0, 0, 5, 5.12], [40, -20, 2, 1.97]] and ds.noise["height"] == 0.03
    for name in os.listdir(out):
        assert (mine / name).read_bytes() == (out / name).read_bytes(), name
    # Each probe at its commanded position: the height reported plus G31's trigger height.
    logged = np.loadtxt(probes, delimiter=",", skiprows=1)
    assert np.array_equal(ds.probes[:, :2], logged[:, :2])
    assert np.allclose(ds.probes[:, 2], logged[:, 2] + 0.7, rtol=0, atol=1e-12)
    assert ds.mechanism == "linear delta" and ds.print_radius == 100.0 and len(ds.distances) == 3
    assert parcal.calibrate(ds).verdict in ("accepted", "rejected")

    # Klipper: printer.cfg's settings and a probe log, as the command makes it.
    printer_cfg = tmp_path / "printer.cfg"
    printer_cfg.write_text("[printer]\nkinematics: delta\ndelta_radius: 135\nprint_radius: 100\n\n"
                           "[stepper_a]\narm_length: 270\nposition_endstop: 300\n\n[stepper_b]\n\n[stepper_c]\n")
    out = tmp_path / "klipper"
    cli("import", "klipper", "--config", printer_cfg, "--probes", probes, "--out", out)
    klipper = tmp_path / "klipper-mine"
    parcal.import_firmware("klipper", printer_cfg, probes=probes).write(klipper)
    for name in os.listdir(out):
        assert (klipper / name).read_bytes() == (out / name).read_bytes(), name

    # Marlin: what M503 reported, the printable radius given, and G30's probe
    # positions less M851's X Y offsets: the nozzle's.
    m503 = tmp_path / "m503.txt"
    m503.write_text("echo:  M665 L270.00 R135.00 H299.30 S200.00 X0.00 Y0.00 Z0.00 A0.00 B0.00 C0.00\n"
                    "echo:  M666 X0.00 Y0.00 Z0.00\n"
                    "echo:  M851 X2.00 Y-3.00 Z-0.70 ; (mm)\nok\n")
    out = tmp_path / "marlin"
    cli("import", "marlin", "--config", m503, "--probes", probes, "--print-radius", 100, "--out", out)
    marlin = parcal.import_firmware("marlin", m503, probes=probes, print_radius=100.0)
    mine = tmp_path / "marlin-mine"
    marlin.write(mine)
    for name in os.listdir(out):
        assert (mine / name).read_bytes() == (out / name).read_bytes(), name
    assert np.allclose(marlin.probes, logged + [-2.0, 3.0, 0.7], rtol=0, atol=1e-12)
    assert marlin.print_radius == 100.0
    with pytest.raises(parcal.Error, match=r"m503.txt: Marlin's M503 reports no printable radius .*: give print_radius="):
        parcal.import_firmware("marlin", m503, probes=probes)
    with pytest.raises(parcal.Error, match="print_radius: reprapfirmware's configuration states its own"):
        parcal.import_firmware("reprapfirmware", config, probes=probes, print_radius=100.0)
    # Compiled-in radius trims (DELTA_RADIUS_TRIM_TOWER), as the command takes them.
    out = tmp_path / "marlin-trims"
    cli("import", "marlin", "--config", m503, "--probes", probes, "--print-radius", 100,
        "--radius-trims", "0.5,-0.25,0", "--out", out)
    trimmed = tmp_path / "marlin-trims-mine"
    parcal.import_firmware("marlin", m503, probes=probes, print_radius=100.0, radius_trims=(0.5, -0.25, 0.0)).write(trimmed)
    for name in os.listdir(out):
        assert (trimmed / name).read_bytes() == (out / name).read_bytes(), name
    configured = json.loads((out / "machine.json").read_text())["configured"]
    assert [configured[f"radius_{t}"] for t in "abc"] == [0.5, -0.25, 0.0]
    with pytest.raises(parcal.Error, match="radius_trims: radius trims are Marlin's"):
        parcal.import_firmware("klipper", printer_cfg, probes=probes, radius_trims=(0.5, 0.0, 0.0))
    with pytest.raises(parcal.Error, match="tower Y's radius trim must be a finite number of mm within 1e6, got NaN"):
        parcal.import_firmware("marlin", m503, probes=probes, print_radius=100.0, radius_trims=(0.0, float("nan"), 0.0))

    # Refusals name what is wrong.
    with pytest.raises(parcal.Error, match=r"printer.cfg: no probe log given, and no probes saved "
                       r"\(run DELTA_CALIBRATE and SAVE_CONFIG\): give probes="):
        parcal.import_firmware("klipper", printer_cfg)
    with pytest.raises(parcal.Error, match="firmware: expected reprapfirmware, klipper or marlin, got \"hangprinter\""):
        parcal.import_firmware("hangprinter", config, probes=probes)
    with pytest.raises(parcal.Error, match=r"tilt_tolerance: 0 is not a standard deviation in \(0, 100\]"):
        parcal.import_firmware("reprapfirmware", config, probes=probes, tilt_tolerance=0.0)
    with pytest.raises(parcal.Error, match="matched_rods: inf is not a standard deviation"):
        parcal.import_firmware("reprapfirmware", config, probes=probes, matched_rods=float("inf"))
    with pytest.raises(parcal.Error, match="nowhere.g"):
        parcal.import_firmware("reprapfirmware", tmp_path / "nowhere.g", probes=probes)
