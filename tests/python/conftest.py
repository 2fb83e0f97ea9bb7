"""pytest setup for the ccfr module: ctest passes where the module and the CLI are built."""
import os
import pathlib
import sys

import pytest

HERE = pathlib.Path(__file__).resolve().parent
SOURCE_DIR = HERE.parent.parent
if os.environ.get("CCFR_PYTHON_DIR"):
    sys.path.insert(0, os.environ["CCFR_PYTHON_DIR"])


@pytest.fixture(scope="session")
def ccfr_exe():
    exe = os.environ.get("CCFR_EXE")
    if not exe:
        pytest.skip("CCFR_EXE is not set (ctest sets it)")
    return exe


@pytest.fixture(scope="session")
def data():
    return HERE / "data"


@pytest.fixture(scope="session")
def source_dir():
    return SOURCE_DIR
