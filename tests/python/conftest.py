"""Shared fixtures of the Python binding's tests (run by CTest as test_python; see python/CMakeLists.txt).

SANDMPM_PYREF names the C reference program (tests/python/pyref.c) that builds the same worlds as
scenes.py with the C API; SANDMPM_SANITIZED=1 in the sanitizer build (the allocator is then ASan's)."""
import os
import subprocess
import sys

import pytest

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

SANITIZED = os.environ.get("SANDMPM_SANITIZED") == "1"


def run_pyref(*args):
    """Runs the C reference program; returns {first word: rest of the line} for each output line."""
    exe = os.environ.get("SANDMPM_PYREF")
    if not exe or not os.path.exists(exe):
        pytest.fail("SANDMPM_PYREF must name the sm_pyref program (CTest's test_python sets it)")
    out = subprocess.run([exe, *args], check=True, capture_output=True, text=True).stdout
    result = {}
    for line in out.splitlines():
        words = line.split()
        result[" ".join(words[:-1])] = words[-1]
    return result


@pytest.fixture
def pyref():
    return run_pyref
