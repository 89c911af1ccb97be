"""parcal.calibrate against the parcal binary, on files and in memory."""

import csv
import json
import threading

import numpy as np
import pytest

import parcal


@pytest.mark.parametrize(
    "options, flags",
    [
        ({}, []),
        ({"prior": "paper", "radius": "contact", "snoop": True}, ["--prior", "paper", "--radius", "contact", "--snoop"]),
        ({"sim": "III", "lm": True, "loss": "huber"}, ["--sim", "III", "--lm", "--loss", "huber"]),
    ],
)
def test_the_paper_fixture_gives_the_calibration_json_of_the_cli(paper, cli, options, flags):
    out = paper.parent / "cli.json"
    status = cli("calibrate", paper, "--out", out, *flags)
    written = out if status == 0 else out.with_name("cli.rejected.json")
    expected = written.read_text()
    run = parcal.calibrate(parcal.Dataset.read(str(paper)), **options)
    assert run.to_json() == expected
    record = json.loads(expected)
    assert run.verdict == record["verdict"]
    assert run.names == record["parameters"]["names"]
    assert np.array_equal(run.values, record["parameters"]["values"])
    assert np.array_equal(run.sigmas, record["parameters"]["sigma"])
    assert np.array_equal(run.covariance, record["covariance"])
    mine = paper.parent / "python.json"
    run.write(mine)
    assert mine.read_text() == expected


def in_memory(path):
    """The dataset at `path` built from its JSON files' dicts and numpy arrays."""
    machine = json.loads((path / "machine.json").read_text())
    artefacts = json.loads((path / "artefacts.json").read_text())
    with open(path / "measurements.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    ball = [row["ball"] for row in rows]
    q = np.array([[float(row[f"q{i}"]) for i in range(1, 7)] for row in rows])
    return machine, artefacts, ball, q


def test_the_same_data_built_in_memory_gives_the_same_values(paper):
    from_files = parcal.calibrate(parcal.Dataset.read(paper))
    machine, artefacts, ball, q = in_memory(paper)
    dataset = parcal.Dataset(machine=machine, artefacts=artefacts, ball=ball, q=q)
    assert dataset.checksum == parcal.Dataset.read(paper).checksum
    assert dataset.ball == ball and np.array_equal(dataset.q, q)
    run = parcal.calibrate(dataset)
    assert run.verdict == from_files.verdict == "accepted"
    assert np.array_equal(run.values, from_files.values)
    assert np.array_equal(run.sigmas, from_files.sigmas)
    assert np.array_equal(run.ball_centres, from_files.ball_centres)
    tests = run.observations
    assert len(tests["kind"]) == len(ball) and set(tests["kind"]) == {"contact"}
    assert np.array_equal(np.sort(tests["index"]), np.arange(len(ball)))
    assert np.all(np.isfinite(tests["normalised_residual"]))


def test_a_dataset_written_reads_back_the_same(paper, tmp_path):
    machine, artefacts, ball, q = in_memory(paper)
    parcal.Dataset(machine, artefacts, ball, q).write(tmp_path / "copy")
    parcal.Dataset.read(paper).write(tmp_path / "copy.bin", snapshot=True)
    original = parcal.Dataset.read(paper).checksum
    assert parcal.Dataset.read(tmp_path / "copy").checksum == original
    assert parcal.Dataset.read(tmp_path / "copy.bin").checksum == original


def test_bad_input_raises_parcal_error_naming_the_row(paper):
    machine, artefacts, ball, q = in_memory(paper)
    q[5, 2] = np.nan
    # Refused where the dataset is built, not when it is first used.
    with pytest.raises(parcal.Error, match=r"measurement row 5, field q3: value NaN is not a finite number"):
        parcal.Dataset(machine, artefacts, ball, q)
    ball[7] = "b99"
    with pytest.raises(parcal.Error, match=r'measurement row 7, field ball: unknown ball id "b99"'):
        parcal.Dataset(machine, artefacts, ball, q)
    with pytest.raises(parcal.Error, match=r"q: expected 6 columns, got 5"):
        parcal.Dataset(machine, artefacts, ball[:-1], q[:, :5])
    # Not cut to their real parts, as numpy's cast would.
    with pytest.raises(parcal.Error, match=r"q: complex numbers, where real ones are expected"):
        parcal.Dataset(machine, artefacts, ball, q + 1e-3j)
    del machine["prior_sigma"]
    with pytest.raises(parcal.Error, match=r"machine.json.*prior_sigma"):
        parcal.Dataset(machine, artefacts)
    assert issubclass(parcal.Error, ValueError)


def test_options_are_the_cli_flags_and_an_unknown_one_is_named(paper):
    dataset = parcal.Dataset.read(paper)
    with pytest.raises(parcal.Error, match=r'unknown option "priors"'):
        parcal.calibrate(dataset, priors="paper")
    with pytest.raises(parcal.Error, match=r'prior: "bogus" is not one of none, paper, propagated'):
        parcal.calibrate(dataset, prior="bogus")
    with pytest.raises(parcal.Error, match=r"max_iterations 10001: must be a whole number from 0 to 10000"):
        parcal.calibrate(dataset, max_iterations=10001)
    with pytest.raises(parcal.Error, match=r"time_limit: -1"):
        parcal.calibrate(dataset, time_limit=-1)
    run = parcal.calibrate(dataset, max_iterations=2)
    assert run.verdict == "rejected" and not run.converged


def test_the_progress_callback_is_called_and_its_exception_stops_the_run(paper, progress_check):
    dataset = parcal.Dataset.read(paper)
    progress_check(lambda **progress: parcal.calibrate(dataset, **progress),
                   lambda run: len(json.loads(run.to_json())["iterations"]))


def test_a_python_thread_runs_while_a_calibration_runs(medium):
    """With a switch interval far beyond the calibration's time, the GIL
    passes to the counter only where a thread releases it: the counter
    releases it at each step (sleep(0)), and the calibration for its whole
    solve. Had it held the GIL, the count would not move during it."""
    import sys

    dataset = parcal.Dataset.read(medium)
    count, stop = [0], threading.Event()

    def counter():
        while not stop.is_set():
            count[0] += 1
            __import__("time").sleep(0)

    interval = sys.getswitchinterval()
    sys.setswitchinterval(100.0)
    thread = threading.Thread(target=counter)
    thread.start()
    try:
        before = count[0]
        run = parcal.calibrate(dataset)
        during = count[0] - before
    finally:
        stop.set()
        thread.join()
        sys.setswitchinterval(interval)
    assert run.converged
    assert during > 0


def test_jugglebot_poses_give_the_calibration_json_of_the_cli(tmp_path, cli):
    from conftest import ROOT

    path = tmp_path / "jugglebot"
    __import__("shutil").copytree(ROOT / "fixtures" / "jugglebot", path)
    cli("calibrate", path, "--out", tmp_path / "cli.json")
    run = parcal.calibrate(parcal.Dataset.read(str(path)))
    assert run.to_json() == (tmp_path / "cli.json").read_text()
    assert run.leg_residuals.shape == (108, 6) and run.point_residuals.shape == (0, 3)
    assert set(run.observations["kind"]) == {"pose"}


def test_touches_poses_and_points_give_one_calibration_with_every_residual(tmp_path, cli, paper):
    path = tmp_path / "mixed"
    cli("simulate", "--seed", "6", "--tracker", "both", "--touches", "--out", path)
    cli("calibrate", path, "--out", tmp_path / "cli.json")
    run = parcal.calibrate(parcal.Dataset.read(str(path)))
    touches = parcal.calibrate(parcal.Dataset.read(str(paper)))
    assert type(run) is type(touches) is parcal.Calibration
    assert run.to_json() == (tmp_path / "cli.json").read_text()
    rows = {name: sum(1 for _ in open(path / f"{name}.csv")) - 1 for name in ("poses", "points")}
    assert run.leg_residuals.shape == (rows["poses"], 6)
    assert run.point_residuals.shape == (rows["points"], 3)
    assert set(run.observations["kind"]) == {"contact", "pose", "point"}
    assert touches.leg_residuals is None and touches.point_residuals is None


def test_poses_built_in_memory_give_the_values_of_the_files(tmp_path):
    from conftest import ROOT

    path = ROOT / "fixtures" / "jugglebot"
    table = np.loadtxt(path / "poses.csv", delimiter=",", skiprows=1)
    machine = json.loads((path / "machine.json").read_text())
    poses = {"q": table[:, 0:6], "position": table[:, 6:9], "orientation": table[:, 9:13]}
    dataset = parcal.Dataset(machine, poses=poses)
    assert dataset.checksum == parcal.Dataset.read(path).checksum
    assert np.array_equal(parcal.calibrate(dataset).values, parcal.calibrate(parcal.Dataset.read(path)).values)
    poses["orientation"] = table[:-1, 9:13]
    with pytest.raises(parcal.Error, match="poses: orientation has 107 rows and q 108"):
        parcal.Dataset(machine, poses=poses)
    with pytest.raises(parcal.Error, match=r'poses: unknown key "sessions" \(its keys are session, q, position, orientation\)'):
        parcal.Dataset(machine, poses={**poses, "sessions": ["1"] * 108})


def test_a_dataset_s_machine_and_a_calibration_s_dict_are_their_files(paper, tmp_path):
    # What a getter returns, the constructor takes back: the same dataset.
    ds = parcal.Dataset.read(paper)
    assert ds.machine == json.loads((paper / "machine.json").read_text())
    _, artefacts, ball, q = in_memory(paper)
    again = parcal.Dataset(ds.machine, artefacts, ball, q)
    assert again.checksum == ds.checksum
    run = parcal.calibrate(ds)
    run.write(tmp_path / "calibration.json")
    assert run.to_dict() == json.loads((tmp_path / "calibration.json").read_text())


def test_a_calibration_read_back_is_the_one_written(paper, tmp_path):
    ds = parcal.Dataset.read(paper)
    run = parcal.calibrate(ds)
    run.write(tmp_path / "calibration.json")
    back = parcal.Calibration.read(tmp_path / "calibration.json")
    assert back.to_json() == (tmp_path / "calibration.json").read_text()
    assert (back.verdict, back.names, back.ball_ids) == (run.verdict, run.names, run.ball_ids)
    assert (back.global_test, back.removed) == (run.global_test, run.removed)
    assert back.iterations == run.iterations == len(run.to_dict()["iterations"])
    np.testing.assert_array_equal(back.prior_sigmas, run.prior_sigmas)
    # The propagated prior's sigma of each of the 33, as the record states it.
    assert run.prior_sigmas.tolist() == run.to_dict()["diagnostics"]["prior_sigma"]
    without = parcal.calibrate(ds, prior="none")
    assert np.isnan(without.prior_sigmas).all() and len(without.prior_sigmas) == 33
    for field in ("values", "sigmas", "covariance", "ball_centres", "ball_centre_sigmas"):
        np.testing.assert_array_equal(getattr(back, field), getattr(run, field))
    # The file keeps the tests' summary, not each test or residual.
    assert back.observations is None and back.normalised_residuals is None
    assert back.leg_residuals is None and back.point_residuals is None
    # What applies a calibration takes it as it takes the run.
    targets = [[0.0, 0.0, 400.0, 0.0, 0.0, 0.0], [20.0, -10.0, 420.0, 0.05, 0.0, 0.0]]
    np.testing.assert_array_equal(
        parcal.compensate(back, targets)["q"], parcal.compensate(run, targets)["q"]
    )
    assert parcal.export(back, "genhexkins") == parcal.export(run, "genhexkins")
    # Another kind of file is refused, naming it and what it is.
    with pytest.raises(parcal.Error, match='machine.json: format "parcal-machine/1" is a parcal-machine file'):
        parcal.Calibration.read(paper / "machine.json")


def test_snooping_s_removals_and_the_global_test_are_the_record_s(paper):
    # One reading 0.5 mm long, found and removed by snooping: `removed`
    # names its line of measurements.csv; the global test is the record's.
    machine, artefacts, ball, q = in_memory(paper)
    q[40, 0] += 0.5
    run = parcal.calibrate(parcal.Dataset(machine, artefacts, ball, q), snoop=True)
    record = run.to_dict()
    assert run.removed == record["removed_observations"]
    assert [r["line"] for r in run.removed] == [42]
    assert run.global_test == record["global_test"]
    assert run.global_test["outcome"] == "consistent"
