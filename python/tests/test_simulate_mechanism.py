"""parcal.simulate with a mechanism (a linear delta, a cable robot) against
``parcal simulate --mechanism``: the same files for the same seed and
options, held-out data of a simulated machine (``truth=``), and each
refusal."""

import numpy as np
import pytest

import parcal
from conftest import ROOT, assert_same_files, flags

DELTA = {
    "probe_rings": 4,
    "probes_per_ring": 6,
    "part_distances": 12,
    "probe_sigma": 0.02,
    "distance_sigma": 0.03,
    "manual_heights": 4,
    "height_sigma": 0.02,
    "balls": 3,
    "points_per_ball": 5,
}
CABLE = {"samples": 30, "known_positions": 5, "reading_sigma": 2.0, "measured_sigma": 0.5}


@pytest.mark.parametrize(("mechanism", "options"), [("delta", DELTA), ("cable", CABLE)])
def test_a_simulated_mechanism_is_the_command_s_byte_for_byte(tmp_path, cli, mechanism, options):
    ds = parcal.simulate(5, mechanism=mechanism, **options)
    assert isinstance(ds, parcal.MechanismDataset) and ds.truth is not None
    ds.write(tmp_path / "python")
    cli("simulate", "--mechanism", mechanism, "--seed", 5, *flags(options), "--out", tmp_path / "cli")
    assert_same_files(tmp_path / "python", tmp_path / "cli")


def test_the_defaults_are_the_command_s(tmp_path, cli):
    for mechanism, long_name in (("delta", "linear delta"), ("cable", "cable robot")):
        ds = parcal.simulate(2, mechanism=long_name)
        assert ds.mechanism == long_name
        ds.write(tmp_path / mechanism)
        cli("simulate", "--mechanism", mechanism, "--seed", 2, "--out", tmp_path / f"{mechanism}-cli")
        assert_same_files(tmp_path / mechanism, tmp_path / f"{mechanism}-cli")


@pytest.mark.parametrize(("mechanism", "options"), [("delta", DELTA), ("cable", CABLE)])
def test_held_out_data_measure_the_truth_again_as_the_command_does(tmp_path, cli, mechanism, options):
    ds = parcal.simulate(5, mechanism=mechanism, **options)
    ds.write(tmp_path / "simulated")
    held_out = parcal.simulate(6, mechanism=mechanism, **options, truth=ds)
    assert np.array_equal(held_out.truth["parameters"], ds.truth["parameters"])
    same = np.array_equal(held_out.probes, ds.probes) and np.array_equal(
        held_out.samples["readings"], ds.samples["readings"]
    )
    assert not same  # new noise
    held_out.write(tmp_path / "python")
    truth = ["--truth", tmp_path / "simulated"]
    cli("simulate", "--mechanism", mechanism, "--seed", 6, *flags(options), *truth, "--out", tmp_path / "cli")
    assert_same_files(tmp_path / "python", tmp_path / "cli")
    # The truth read back from its files is the same true machine.
    again = parcal.simulate(6, mechanism=mechanism, **options, truth=parcal.MechanismDataset.read(tmp_path / "simulated"))
    again.write(tmp_path / "again")
    assert_same_files(tmp_path / "again", tmp_path / "cli")


def test_held_out_data_that_cannot_be_judged_on_are_refused():
    delta = parcal.simulate(5, mechanism="delta", probe_rings=4)
    with pytest.raises(parcal.Error, match=r"truth \(in memory\): these are its own measurements \(the same seed"):
        parcal.simulate(5, mechanism="delta", probe_rings=4, truth=delta)
    cable = parcal.simulate(5, mechanism="cable")
    with pytest.raises(parcal.Error, match="truth .*: a dataset of a cable robot, not of a linear delta"):
        parcal.simulate(6, mechanism="delta", truth=cable)
    with pytest.raises(parcal.Error, match="^truth: a dataset of a hexapod, not of a linear delta"):
        parcal.simulate(6, mechanism="delta", truth=parcal.simulate(1))
    with pytest.raises(parcal.Error, match="^truth: expected a simulated parcal.MechanismDataset"):
        parcal.simulate(6, mechanism="delta", truth=str(ROOT / "fixtures" / "hangprinter"))
    hangprinter = parcal.MechanismDataset.read(ROOT / "fixtures" / "hangprinter")
    with pytest.raises(parcal.Error, match="hangprinter: the dataset has no truth.json"):
        parcal.simulate(6, mechanism="cable", truth=hangprinter)
    with pytest.raises(parcal.Error, match=r"^truth apply to a mechanism other than the hexapod"):
        parcal.simulate(6, truth=delta)


@pytest.mark.parametrize(
    ("mechanism", "options", "message"),
    [
        ("delta", {"samples": 20, "measured_sigma": 2.0}, "samples, measured_sigma do not apply to a linear delta"),
        ("cable", {"probe_rings": 2, "points_per_ball": 5}, "probe_rings, points_per_ball do not apply to a cable robot"),
        ("cable", {"balls": 3}, "balls do not apply to a cable robot"),
        ("delta", {"tilt": 5.0, "design_drawn": True}, "tilt, design_drawn do not apply to a linear delta"),
        (None, {"probe_rings": 2, "samples": 3}, "probe_rings, samples apply to a mechanism other than the hexapod"),
        ("scara", {}, 'mechanism "scara": unknown'),
    ],
)
def test_an_option_of_another_mechanism_is_refused_naming_it(mechanism, options, message):
    with pytest.raises(parcal.Error, match=f"^{message}"):
        parcal.simulate(1, mechanism=mechanism, **options)


@pytest.mark.parametrize(
    ("mechanism", "options", "message"),
    [
        ("delta", {"probe_rings": 21}, "probe_rings 21: must be a whole number from 1 to 20"),
        ("delta", {"probe_rings": 0}, "probe_rings 0: must be a whole number from 1 to 20"),
        ("delta", {"probes_per_ring": 2}, "probes_per_ring 2: must be a whole number from 3 to 360"),
        ("delta", {"part_distances": 181}, "part_distances 181: must be a whole number from 0 to 180"),
        ("delta", {"balls": 0}, "balls 0: must be a whole number from 1 to 10000000"),
        ("delta", {"balls": 250001}, "balls 250001: must be a whole number from 1 to 250000"),
        ("delta", {"balls": 2, "points_per_ball": 0}, "points_per_ball 0: must be a whole number from 1"),
        ("delta", {"probe_sigma": 0.0}, r"probe_sigma must be in \(0, 1\], got 0"),
        ("delta", {"distance_sigma": float("nan")}, r"distance_sigma must be in \(0, 1\], got NaN"),
        ("delta", {"manual_heights": 1001}, "manual_heights 1001: must be a whole number from 0 to 1000"),
        ("delta", {"height_sigma": -0.1}, r"height_sigma must be in \(0, 1\], got -0.1"),
        ("cable", {"samples": 10001}, "samples 10001: must be a whole number from 1 to 10000"),
        ("cable", {"samples": 20, "known_positions": 30}, "known_positions 30 is more than the 20 samples"),
        ("cable", {"reading_sigma": 91.0}, r"reading_sigma must be in \(0, 90\], got 91"),
    ],
)
def test_every_count_and_sigma_is_bounded_as_the_command_bounds_it(mechanism, options, message):
    with pytest.raises(parcal.Error, match=message):
        parcal.simulate(1, mechanism=mechanism, **options)


def test_the_hexapod_is_still_simulated_without_a_mechanism():
    for mechanism in (None, "hexapod"):
        ds = parcal.simulate(1, mechanism=mechanism, balls=4, points_per_ball=3)
        assert isinstance(ds, parcal.Dataset) and ds.q.shape == (12, 6)


ELASTIC = {"zero_loads": [15.0, 15.0, 15.0, 30.0], "compliance_of_line": [0, 0, 1, 1], "load_range": (10.0, 30.0)}
ELASTIC_FLAGS = ["--zero-loads", "15,15,15,30", "--compliance-of-line", "0,0,1,1", "--load-range", "10,30"]


def test_elastic_lines_are_the_command_s_with_their_loads(tmp_path, cli):
    ds = parcal.simulate(4, mechanism="cable", **ELASTIC)
    # The rigid robot's 19 parameters and two compliances.
    assert len(ds.truth["parameters"]) == 21
    loads = ds.samples["loads"]
    assert loads.shape == (44, 4)
    assert np.array_equal(loads[0], ELASTIC["zero_loads"])
    assert np.all((loads[1:] >= 10.0) & (loads[1:] < 30.0))
    ds.write(tmp_path / "python")
    cli("simulate", "--mechanism", "cable", "--seed", 4, *ELASTIC_FLAGS, "--out", tmp_path / "cli")
    assert_same_files(tmp_path / "python", tmp_path / "cli")
    # Held out: the true machine's lines, under loads of their own.
    held_out = parcal.simulate(5, mechanism="cable", truth=ds)
    held_out.write(tmp_path / "held-out")
    truth = ["--truth", tmp_path / "cli"]
    cli("simulate", "--mechanism", "cable", "--seed", 5, *truth, "--out", tmp_path / "held-out-cli")
    assert_same_files(tmp_path / "held-out", tmp_path / "held-out-cli")
    assert not np.array_equal(held_out.samples["loads"][1:], loads[1:])
    with pytest.raises(parcal.Error, match=r"^zero_loads with truth \(in memory\): the true machine's lines"):
        parcal.simulate(5, mechanism="cable", truth=ds, zero_loads=[1.0, 2.0, 3.0, 4.0])
    with pytest.raises(parcal.Error, match="^load_range needs zero_loads"):
        parcal.simulate(5, mechanism="cable", load_range=(1.0, 2.0))
    with pytest.raises(parcal.Error, match=r"the loads' range \[30, 10\] N must be within"):
        parcal.simulate(5, mechanism="cable", zero_loads=[15.0] * 4, load_range=(30.0, 10.0))
    with pytest.raises(parcal.Error, match="zero_loads do not apply to a linear delta"):
        parcal.simulate(5, mechanism="delta", zero_loads=[15.0] * 4)


@pytest.mark.parametrize(
    ("options", "free_parameters", "quantile"),
    [
        # chi-square's 99.9 % quantiles: 13 degrees of freedom (a delta's
        # 16 and the trigger height less its four gauge-fixed canonical
        # parameters), 19 (a cable robot's, its gauge held by the priors).
        ({"mechanism": "delta", "probe_rings": 3, "part_distances": 6}, 13, 34.53),
        ({"mechanism": "cable", "samples": 40, "known_positions": 8}, 19, 43.82),
    ],
)
def test_the_truth_is_in_the_terms_of_the_calibration_s_values(options, free_parameters, quantile):
    ds = parcal.simulate(4, **options)
    run = parcal.calibrate(ds)
    truth = ds.truth
    assert run.names == truth["names"]
    error = run.values - truth["values"]
    # The canonical frame fixes some parameters exactly (zero variance):
    # there the estimate is the truth; over the others the NEES of an
    # honest covariance is chi-square distributed.
    free = np.diag(run.covariance) > 0
    assert free.sum() == free_parameters
    assert np.all(error[~free] == 0)
    covariance = run.covariance[np.ix_(free, free)]
    nees = error[free] @ np.linalg.solve(covariance, error[free])
    assert nees < quantile, nees
