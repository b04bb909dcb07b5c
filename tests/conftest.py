"""Shared fixtures: where the Middlebury development data lives, a small pair on disk."""

import os
from pathlib import Path

# Under pytest-xdist each worker keeps numba's compiled kernels in a cache folder of its
# own, set before numba is imported: two processes writing entries of one function's
# cache index at once can pair a signature with another's machine code (numba#4807).
if os.environ.get("PYTEST_XDIST_WORKER"):
    _cache = (
        os.environ.get("NUMBA_CACHE_DIR") or Path(__file__).resolve().parents[1] / ".numba-cache"
    )
    os.environ["NUMBA_CACHE_DIR"] = os.path.join(_cache, os.environ["PYTEST_XDIST_WORKER"])

import numpy as np  # noqa: E402
import pytest  # noqa: E402
from PIL import Image  # noqa: E402

import synthetic  # noqa: E402
from dcstereo.evaluation.datasets import list_middlebury, middlebury_dir  # noqa: E402


@pytest.fixture(scope="session")
def middlebury_root():
    """The Middlebury scene folder, or skip the test when the data is absent."""
    folder = middlebury_dir()
    if not list_middlebury():
        pytest.skip(f"Middlebury dev data not found at {folder}; set DCSTEREO_DATA")
    return folder


@pytest.fixture
def pair(tmp_path):
    """``left.png`` and ``right.png`` of a textured object before a background, and the truth.

    24 x 64, disparities 2 (background) and 8 (object); ``(folder, truth)``. Modules with
    a ``pair`` of their own use theirs.
    """
    rng = np.random.default_rng(101)
    left, right, truth = synthetic.object_pair(rng, 24, 64, 2, 8, (24, 44))
    Image.fromarray(left).save(tmp_path / "left.png")
    Image.fromarray(right).save(tmp_path / "right.png")
    return tmp_path, truth


@pytest.fixture
def refuse_move(monkeypatch):
    """``refuse_move(name, error=None)``: make ``os.replace`` of a hidden temporary file onto
    a path named ``name`` raise ``error`` (a permission error by default); other moves run."""
    real = os.replace

    def refuse(name, error=None):
        error = error or PermissionError(13, "Permission denied")

        def replace(src, dst):
            if os.path.basename(dst) == name and os.path.basename(src).startswith("."):
                raise error
            return real(src, dst)

        monkeypatch.setattr(os, "replace", replace)

    return refuse
