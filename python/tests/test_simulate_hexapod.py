"""parcal.simulate of a hexapod against ``parcal simulate``: instrument
campaigns (``tracker=``), readings in revolutions and plans (a plan.csv's
path or the dict ``parcal.plan`` returns) give the command's files for the
same seed and options, and every combination the command refuses is
refused, naming the keyword."""

import importlib.util
import sys

import numpy as np
import pytest

import parcal
from conftest import ROOT, assert_same_files, flags

TOUCH_FILES = {"artefacts.json", "machine.json", "measurements.csv", "truth.json"}


@pytest.mark.parametrize(
    ("options", "files"),
    [
        (
            {"tracker": "both", "sessions": 2, "rows": 10, "rehome": 0.5},
            {"machine.json", "poses.csv", "points.csv", "truth.json"},
        ),
        (
            {"tracker": "poses", "machine": "jugglebot", "rehome": 2, "position_sigma": 0.3,
             "orientation_sigma": 0.001, "rows": 20, "tilt": 15},
            {"machine.json", "poses.csv", "truth.json"},
        ),
        ({"tracker": "points", "sessions": 1}, {"machine.json", "points.csv", "truth.json"}),
        ({"tracker": "both", "touches": True, "rows": 10}, TOUCH_FILES | {"poses.csv", "points.csv"}),
        ({"readings": "rev", "balls": 8, "points_per_ball": 5}, TOUCH_FILES),
        ({"readings": "mm", "design_drawn": True}, TOUCH_FILES),
    ],
)
def test_a_hexapod_campaign_is_the_command_s_byte_for_byte(tmp_path, cli, options, files):
    ds = parcal.simulate(3, **options)
    assert isinstance(ds, parcal.Dataset)
    ds.write(tmp_path / "python")
    assert {p.name for p in (tmp_path / "python").iterdir()} == files
    cli("simulate", "--seed", 3, *flags(options), "--out", tmp_path / "cli")
    assert_same_files(tmp_path / "python", tmp_path / "cli")


def test_the_options_reach_the_dataset():
    ds = parcal.simulate(3, tracker="poses", sessions=2, rows=6, rehome=0.5, position_sigma=0.02)
    assert ds.poses["q"].shape == (12, 6) and len(ds.points["q"]) == 0
    assert sorted(set(ds.poses["session"])) == ["1", "2"]
    assert ds.machine["session_model"]["leg_offset_sigma"] == 0.5
    assert ds.machine["repeatability"]["position"] == 0.02
    rev = parcal.simulate(3, readings="rev")
    assert rev.machine["actuator"]["unit"] == "rev"
    assert not np.array_equal(rev.q, parcal.simulate(3).q)


def test_a_plan_is_simulated_from_its_file_or_its_dict_as_the_command_does(tmp_path, cli):
    template = tmp_path / "template"
    cli("simulate", "--balls", 8, "--points-per-ball", 5, "--out", template)
    plan_csv = tmp_path / "plan.csv"
    cli("plan", template, "--contacts", 40, "--tilt", 20, "--pool", 2000, "--out", plan_csv)
    cli("simulate", "--seed", 2, "--balls", 8, "--plan", plan_csv, "--out", tmp_path / "cli")
    planned = parcal.plan(parcal.Dataset.read(template), 40, 20, pool=2000)
    from_dict = parcal.simulate(2, balls=8, plan=planned)
    assert from_dict.contacts == 40
    from_dict.write(tmp_path / "dict")
    assert_same_files(tmp_path / "dict", tmp_path / "cli")
    parcal.simulate(2, balls=8, plan=plan_csv).write(tmp_path / "file")
    assert_same_files(tmp_path / "file", tmp_path / "cli")
    # The planned touches, not random ones.
    assert not np.array_equal(from_dict.q, parcal.simulate(2, balls=8, points_per_ball=5).q[:40])


def test_a_pose_plan_is_simulated_in_its_sessions_as_the_command_does(tmp_path, cli):
    template = tmp_path / "template"
    cli("simulate", "--tracker", "poses", "--sessions", 1, "--rows", 6, "--out", template)
    plan_csv = tmp_path / "plan.csv"
    cli("plan", template, "--poses", 6, "--tilt", 10, "--workspace", "60,300,380", "--sessions", 2,
        "--out", plan_csv)
    cli("simulate", "--seed", 4, "--tracker", "both", "--plan", plan_csv, "--out", tmp_path / "cli")
    planned = parcal.plan(parcal.Dataset.read(template), tilt=10, poses=6, workspace=(60, 300, 380),
                          sessions=2)
    assert sorted(set(planned["session"])) == ["1", "2"]
    ds = parcal.simulate(4, tracker="both", plan=planned)
    assert ds.poses["q"].shape == (6, 6)
    ds.write(tmp_path / "dict")
    assert_same_files(tmp_path / "dict", tmp_path / "cli")
    parcal.simulate(4, tracker="both", plan=str(plan_csv)).write(tmp_path / "file")
    assert_same_files(tmp_path / "file", tmp_path / "cli")
    with pytest.raises(parcal.Error, match="^sessions=3 and plan: the plan has 2 sessions"):
        parcal.simulate(4, tracker="both", plan=planned, sessions=3)
    with pytest.raises(parcal.Error, match="^rows and plan: the plan's 3 poses per session"):
        parcal.simulate(4, tracker="both", plan=planned, rows=3)


TOUCH = {"ball": ["b01"], "direction": [[0.0, 0.0, -1.0]], "angles": [[0.0, 0.0, 0.0]]}


@pytest.mark.parametrize(
    ("options", "message"),
    [
        ({"tracker": "both", "balls": 3, "plate": "all"}, "balls, plate cannot be used with tracker"),
        ({"tracker": "poses", "readings": "mm"}, "readings cannot be used with tracker"),
        ({"tracker": "points", "design_drawn": True}, "design_drawn cannot be used with tracker"),
        ({"sessions": 2, "rehome": 0.5}, "sessions, rehome cannot be used without tracker"),
        ({"machine": "paper", "touches": True}, "machine, touches cannot be used without tracker"),
        ({"mechanism": "delta", "tracker": "poses"}, "tracker do not apply to a linear delta"),
        ({"mechanism": "cable", "readings": "rev", "plan": "plan.csv"}, "readings, plan do not apply to a cable robot"),
        ({"tracker": "laser"}, 'tracker: "laser" is not one of poses, points, both'),
        ({"tracker": "poses", "machine": "stewart"}, 'machine: "stewart" is not one of paper, jugglebot'),
        ({"readings": "revolutions"}, 'readings: "revolutions" is not one of mm, rev'),
        ({"tracker": "both", "touches": True, "machine": "jugglebot"},
         r"touches: the ball touches are the paper machine's \(machine=\"paper\"\)"),
        ({"tracker": "points", "rows": 0}, "rows 0: must be a whole number from 1 to 10000000"),
        ({"tracker": "points", "sessions": 0}, "sessions 0: must be a whole number from 1 to 10000000"),
        ({"tracker": "both", "sessions": 10**6, "rows": 10**6}, "too large: sessions 1000000 x rows 1000000"),
        ({"balls": 10**7, "points_per_ball": 2}, "too large: balls 10000000 x points_per_ball 2"),
        ({"tracker": "poses", "rehome": -1}, r"rehome must be a sigma in mm \(0: none\), got -1"),
        ({"tracker": "poses", "position_sigma": 0}, "position_sigma must be positive, got 0"),
        ({"tracker": "poses", "orientation_sigma": float("nan")}, "orientation_sigma must be positive, got NaN"),
        ({"tilt": 90, "tracker": "poses"}, r"tilt must be in \[0, 90\) degrees, got 90"),
        ({"plan": 3}, "plan: expected a plan.csv's path or the dict parcal.plan returns, got 3"),
        ({"plan": {"ball": ["b01"]}}, 'plan: missing "direction"'),
        ({"plan": {**TOUCH, "ball": "b01"}}, r'plan\["ball"\]: expected a sequence of strings'),
        ({"plan": {**TOUCH, "ball": ["b01", "b02"]}}, "plan: ball, direction and angles have 2, 1 and 1 rows"),
        ({"plan": {**TOUCH, "direction": [[0.0, 0.0, -1.1]]}}, r"plan: row 0: u = \(0, 0, -1.1\) is not a unit vector"),
        ({"plan": {**TOUCH, "angles": [[0.0, float("inf"), 0.0]]}}, "plan: row 0: direction .* must be finite"),
        ({"plan": {**TOUCH, "ball": ["b28"]}}, 'plan: row 0: ball "b28" is not one of the simulated balls b01 .. b27'),
        ({"plan": {k: np.empty((0, 3)) for k in ("direction", "angles")} | {"ball": []}}, "plan: no touches"),
        ({"plan": TOUCH, "tracker": "poses"}, r'plan: missing "session" \(a plan of poses'),
        ({"plan": {"session": ["1"], "q": [[1.0] * 5 + [np.inf]]}, "tracker": "poses"}, r"plan: row 0: q \[.*\] must be finite"),
        ({"plan": {"session": [""], "q": [[1.0] * 6]}, "tracker": "poses"}, 'plan: row 0: session "": expected a label'),
        ({"plan": {"session": ["a", "b", "a"], "q": [[1.0] * 6] * 3}, "tracker": "poses"},
         'plan: session "b" has 1 poses and session "a" 2'),
    ],
)
def test_what_the_command_refuses_is_refused_naming_the_keyword(options, message):
    with pytest.raises(parcal.Error, match=f"^{message}"):
        parcal.simulate(1, **options)


def test_a_missing_plan_file_is_named(tmp_path):
    missing = tmp_path / "nothing.csv"
    for tracker in (None, "poses"):
        with pytest.raises(parcal.Error, match="nothing.csv"):
            parcal.simulate(1, tracker=tracker, plan=missing)


def _canonical_frame(joints):
    """Rows x, y, z of the canonical frame of three joints (paper 2.1):
    origin at the first, +y towards the second, the third in z = 0, +z on
    the input frame's +z side."""
    first, second, third = np.asarray(joints[:3], float)
    y = (second - first) / np.linalg.norm(second - first)
    x = (third - first) - (third - first).dot(y) * y
    x /= np.linalg.norm(x)
    if np.cross(x, y)[2] < 0:
        x = -x
    return np.array([x, y, np.cross(x, y)])


def test_a_simulated_dataset_s_truth_is_in_its_calibration_s_terms(tmp_path):
    ds = parcal.simulate(1)
    truth = ds.truth
    # The 33 canonical parameters, formed here from truth.json's geometry
    # by the paper's frames (section 2.1), not by parcal's code.
    g = truth["geometry"]
    base, platform = np.array(g["base_joints"]), np.array(g["platform_joints"])
    rb, re = _canonical_frame(base), _canonical_frame(platform)
    b, e = (base - base[0]) @ rb.T, (platform - platform[0]) @ re.T
    tool = (np.array(g["tool"]) - platform[0]) @ re.T
    canonical = np.concatenate(
        [[b[1, 1], b[2, 0], b[2, 1]], b[3:].ravel(), g["leg_lengths"],
         [e[1, 1], e[2, 0], e[2, 1]], e[3:].ravel(), tool]
    )
    # Sums of products of numbers below 1000 mm: rounding.
    np.testing.assert_allclose(truth["canonical"], canonical, rtol=0, atol=1e-9)
    # Calibrated with the default options (the propagated prior), the
    # estimate's error has the NEES of a chi-square with 33 degrees of
    # freedom if its covariance is honest: under its 99.9 % quantile, 63.9;
    # every centre coordinate within 4.5 sigma (81 of them: each beyond it
    # with probability 6.8e-6).
    run = parcal.calibrate(ds)
    assert run.names[:33] == truth["names"]
    error = run.values[:33] - truth["canonical"]
    nees = error @ np.linalg.solve(run.covariance[:33, :33], error)
    assert nees < 63.9, nees
    assert run.ball_ids == ds.ball_ids
    centres = (run.ball_centres - truth["ball_centres"]) / run.ball_centre_sigmas
    assert np.abs(centres).max() < 4.5
    assert truth["ball_radii"].shape == (27,) and truth["actuator_scale"] is None
    # Written and read back, the same truth; measured data have none.
    ds.write(tmp_path / "sim")
    back = parcal.Dataset.read(tmp_path / "sim").truth
    for key in ("canonical", "ball_centres", "ball_radii"):
        np.testing.assert_array_equal(back[key], truth[key])
    assert parcal.Dataset.read(ROOT / "fixtures" / "jugglebot").truth is None


def test_legs_read_in_revolutions_have_their_true_scales_in_the_truth():
    # The scales are unknowns after the 33 (s_1..s_6, mm a revolution):
    # each estimate within 4 sigma of the truth.
    ds = parcal.simulate(2, readings="rev")
    run = parcal.calibrate(ds)
    assert run.names[33:39] == [f"s_{i}" for i in range(1, 7)]
    scales = ds.truth["actuator_scale"]
    assert np.all(np.abs(run.values[33:39] - scales) < 4 * run.sigmas[33:39])


@pytest.mark.parametrize(
    ("options", "error"),
    [({"balls": -3}, OverflowError), ({"balls": "many"}, TypeError), ({"seed": -1}, OverflowError)],
)
def test_an_argument_python_cannot_convert_is_refused_naming_it(options, error):
    # docs/python.md, "Errors": Python's own error, its note naming the
    # argument (notes are Python 3.11's).
    with pytest.raises(error) as raised:
        parcal.simulate(**options)
    if sys.version_info >= (3, 11):
        name = next(iter(options))
        assert f"while processing '{name}'" in raised.value.__notes__


def test_the_strategies_example_judges_each_strategy_on_each_campaign():
    # python/examples/strategies.py on two campaigns: a row per campaign
    # for every strategy, every figure finite.
    spec = importlib.util.spec_from_file_location(
        "strategies", ROOT / "python" / "examples" / "strategies.py"
    )
    example = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(example)
    results = example.main(2)
    assert set(results) == set(example.STRATEGIES)
    for rows in results.values():
        assert len(rows) == 2
        assert all(np.isfinite(row[1:]).all() for row in rows)
