# The Python module's tests (pytest): ctest runs them with PYTHONPATH at the built module
# (build/python) and PNEUMO at the command line (build/bin/pneumo), which the tests compare it with.
import os
import pathlib
import subprocess

import pytest

REPO = pathlib.Path(__file__).resolve().parents[2]
MODELS = REPO / "models_mjcf"


@pytest.fixture(scope="session")
def models():
    return MODELS


@pytest.fixture(scope="session")
def pneumo():
    """Runs build/bin/pneumo with the arguments given; fails the test with its stderr if it fails."""
    binary = os.environ.get("PNEUMO", str(REPO / "build" / "bin" / "pneumo"))

    def run(*args):
        done = subprocess.run([binary, *map(str, args)], capture_output=True, text=True)
        assert done.returncode == 0, done.stderr
        return done

    return run
