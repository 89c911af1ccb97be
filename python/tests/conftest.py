"""Fixtures of the package's tests: the repository's datasets, and the
parcal binary (PARCAL_CLI, default target/debug/parcal) to compare with."""

import os
import shutil
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]


def flags(options):
    """The command's flags of keyword arguments ``options`` (``True``: the
    flag alone)."""
    out = []
    for name, value in options.items():
        out.append("--" + name.replace("_", "-"))
        if value is not True:
            out.append(value)
    return out


def assert_same_files(written, expected):
    """The directories hold the same files, byte for byte."""
    names = sorted(p.name for p in written.iterdir())
    assert names == sorted(p.name for p in expected.iterdir())
    for name in names:
        assert (written / name).read_bytes() == (expected / name).read_bytes(), name


@pytest.fixture(scope="session")
def cli_output():
    """Runs the parcal binary with the given arguments; returns the finished
    process (its returncode, stdout and stderr), whatever its exit status."""
    binary = Path(os.environ.get("PARCAL_CLI", ROOT / "target" / "debug" / "parcal"))
    assert binary.is_file(), f"{binary}: no parcal binary (cargo build -p parcal-cli, or set PARCAL_CLI)"

    def run(*args):
        return subprocess.run([str(binary), *map(str, args)], capture_output=True, text=True)

    return run


@pytest.fixture(scope="session")
def cli(cli_output):
    """Runs the parcal binary with the given arguments; returns its exit status."""

    def run(*args):
        done = cli_output(*args)
        assert done.returncode in (0, 3), done.stderr
        return done.returncode

    return run


@pytest.fixture
def paper(tmp_path):
    """A copy of fixtures/paper-seed1: the paper's scenario, 189 touches of 27 balls."""
    path = tmp_path / "paper-seed1"
    shutil.copytree(ROOT / "fixtures" / "paper-seed1", path)
    return path


@pytest.fixture(scope="session")
def delta(tmp_path_factory, cli):
    """A simulated linear delta: 33 probe heights on 4 rings and 12 part distances, with its truth."""
    path = tmp_path_factory.mktemp("delta") / "delta"
    cli("simulate", "--mechanism", "delta", "--seed", 5, "--probe-rings", 4, "--part-distances", 12, "--out", path)
    return path


@pytest.fixture(scope="session")
def medium(tmp_path_factory, cli):
    """A simulated campaign of 300 balls touched 7 times each (2100 contacts)."""
    path = tmp_path_factory.mktemp("medium") / "data"
    cli("simulate", "--seed", 2, "--balls", 300, "--out", path)
    return path


@pytest.fixture(scope="session")
def progress_check():
    """Checks that `calibrate(progress=...)` calls its callback once per
    iteration, numbered from 1, `iterations(run)` times, and that an
    exception the callback raises at the second stops the run and is
    raised; returns the run and the records seen."""

    def check(calibrate, iterations):
        seen = []
        run = calibrate(progress=seen.append)
        assert [s["iteration"] for s in seen] == list(range(1, len(seen) + 1))
        assert len(seen) == iterations(run) > 1
        records = list(seen)

        def stop(record):
            seen.append(record)
            if record["iteration"] == 2:
                raise KeyError("enough")

        seen.clear()
        with pytest.raises(KeyError, match="enough"):
            calibrate(progress=stop)
        assert len(seen) == 2
        return run, records

    return check
