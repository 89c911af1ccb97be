"""parcal.report against `parcal report`: the same page, byte for byte,
for a hexapod's own calibration, a mechanism's and a hexapod's through
the common path; what a dataset adds; refusals named."""

import pytest

import parcal


def reported(cli, calibration, dataset, out):
    """The CLI's report.html and report.md of `calibration` with `dataset`."""
    cli("report", calibration, "--dataset", dataset, "--out", out)
    return (out / "report.html").read_text(), (out / "report.md").read_text()


def test_a_hexapods_report_is_the_commands(paper, cli, tmp_path):
    calibration = tmp_path / "calibration.json"
    cli("calibrate", paper, "--out", calibration)
    html, markdown = reported(cli, calibration, paper, tmp_path / "cli")
    ds = parcal.read_dataset(paper)
    assert parcal.report(str(calibration), dataset=ds) == html
    assert parcal.report(str(calibration), dataset=ds, format="markdown") == markdown
    # Without the dataset the design machine of calibration.json places the map.
    alone = parcal.report(parcal.calibrate(ds), format="markdown")
    assert "in memory" in alone and "accepted" in alone.lower()

    # Another campaign is not the dataset calibrated: refused unless asked for.
    other = tmp_path / "other"
    cli("simulate", "--seed", 7, "--out", other)
    other = parcal.read_dataset(other)
    with pytest.raises(parcal.Error, match="the calibration is of another dataset .*give other_data=True"):
        parcal.report(str(calibration), dataset=other)
    assert parcal.report(str(calibration), dataset=other, other_data=True).startswith("<!DOCTYPE html>")


def test_a_mechanisms_report_is_the_commands(delta, paper, cli, tmp_path):
    calibration = tmp_path / "calibration.json"
    cli("calibrate", delta, "--out", calibration)
    html, markdown = reported(cli, calibration, delta, tmp_path / "cli")
    ds = parcal.read_dataset(delta)
    assert parcal.report(str(calibration), dataset=ds) == html
    title, rest = parcal.report(parcal.MechanismCalibration.read(calibration), dataset=ds,
                                format="markdown").split("\n", 1)
    assert title == "# Calibration of a linear delta (in memory)" and rest == markdown.split("\n", 1)[1]
    # The truth adds its columns, the probes their residuals over the bed.
    bare = parcal.report(str(calibration), format="markdown")
    assert "error / sigma" in markdown and "error / sigma" not in bare
    # Another printer's data are not the dataset calibrated: refused unless asked for.
    other = tmp_path / "other-delta"
    cli("simulate", "--mechanism", "delta", "--seed", 9, "--out", other)
    other = parcal.read_dataset(other)
    with pytest.raises(parcal.Error, match="the calibration is of another dataset .*give other_data=True"):
        parcal.report(str(calibration), dataset=other)
    assert parcal.report(str(calibration), dataset=other, other_data=True).startswith("<!DOCTYPE html>")

    # A hexapod through the common path, its truth from the hexapod dataset.
    common = tmp_path / "common.json"
    cli("calibrate", paper, "--common", "--out", common)
    html, _ = reported(cli, common, paper, tmp_path / "common")
    assert parcal.report(str(common), dataset=parcal.read_dataset(paper)) == html

    # Refusals name what is wrong.
    with pytest.raises(parcal.Error, match="a linear delta calibration; the dataset is a hexapod's"):
        parcal.report(str(calibration), dataset=parcal.read_dataset(paper))
    with pytest.raises(parcal.Error, match="a hexapod's own calibration; the dataset is a linear delta's"):
        parcal.report(parcal.calibrate(parcal.read_dataset(paper)), dataset=ds)
    with pytest.raises(parcal.Error, match="format: expected html or markdown, got \"pdf\""):
        parcal.report(str(calibration), format="pdf")
    with pytest.raises(parcal.Error, match="dataset: expected a parcal.Dataset or a parcal.MechanismDataset"):
        parcal.report(str(calibration), dataset=str(delta))
    with pytest.raises(parcal.Error, match="nowhere.json"):
        parcal.report(str(tmp_path / "nowhere.json"))
