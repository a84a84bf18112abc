# The module under test and the tool beside it: ctest sets PYTHONPATH to <build>/python,
# IDAS_CLI to the idas binary of the same build and IDAS_DATA_DIR to data/.
import os
import pathlib
import subprocess

import pytest

import idas

DATA = pathlib.Path(os.environ.get("IDAS_DATA_DIR", pathlib.Path(__file__).parents[2] / "data"))


@pytest.fixture(scope="session")
def data():
    return DATA


@pytest.fixture(scope="session")
def bunny(data):
    """data/bunny.off: (vertices, faces)."""
    return idas.read(data / "bunny.off")[:2]


@pytest.fixture(scope="session")
def cli():
    """Runs the idas tool with arguments; returns its stdout, fails the test on exit != 0."""
    binary = os.environ.get("IDAS_CLI")
    if not binary:
        pytest.skip("IDAS_CLI is not set (ctest sets it to the tool of the same build)")

    def run(*args):
        done = subprocess.run([binary, *map(str, args)], capture_output=True, text=True)
        assert done.returncode == 0, f"idas {' '.join(map(str, args))}: {done.stderr}"
        return done.stdout

    return run
