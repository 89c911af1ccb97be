"""Fixtures of the package's tests: the repository's datasets, and the
parcal binary (PARCAL_CLI, default target/debug/parcal) to compare with."""

import os
import shutil
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="session")
def cli():
    """Runs the parcal binary with the given arguments; returns its exit status."""
    binary = Path(os.environ.get("PARCAL_CLI", ROOT / "target" / "debug" / "parcal"))
    assert binary.is_file(), f"{binary}: no parcal binary (cargo build -p parcal-cli, or set PARCAL_CLI)"

    def run(*args):
        done = subprocess.run([str(binary), *map(str, args)], capture_output=True, text=True)
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
def medium(tmp_path_factory, cli):
    """A simulated campaign of 300 balls touched 7 times each (2100 contacts)."""
    path = tmp_path_factory.mktemp("medium") / "data"
    cli("simulate", "--seed", 2, "--balls", 300, "--out", path)
    return path
