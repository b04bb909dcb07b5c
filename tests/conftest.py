"""Shared fixtures: where the Middlebury development data lives, a small pair on disk."""

import os
import sys
from pathlib import Path

# Every process of the run (the pytest-xdist workers, the processes the tests start) shares
# one numba cache folder, each kernel compiled once: tests/_site/kernel_cache_lock.py
# serialises the compile and save of each cached function across processes (numba#4807),
# installed here and, through tests/_site/sitecustomize.py, in the processes tests start.
_SITE = Path(__file__).resolve().parent / "_site"
os.environ.setdefault("NUMBA_CACHE_DIR", str(Path(__file__).resolve().parents[1] / ".numba-cache"))
os.environ["DCSTEREO_TEST_CACHE_LOCK"] = "1"
os.environ["PYTHONPATH"] = os.pathsep.join(
    [str(_SITE), *filter(None, [os.environ.get("PYTHONPATH")])]
)
sys.path.insert(0, str(_SITE))

import kernel_cache_lock  # noqa: E402

kernel_cache_lock.install()

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


def pytest_collection_modifyitems(config, items):
    """Start the tests marked ``early`` first, each on a worker of its own.

    pytest-xdist's work stealing hands each of the n workers a run of 1/n of the list at
    the start, and moves tests from the end of one run to a worker that is done. A long
    test at the end of a run is the run's tail on one core, so each ``early`` test goes to
    the front of a run of its own (the first ones, where there are more than workers).
    """
    early = [item for item in items if item.get_closest_marker("early")]
    if not early:
        return
    rest = [item for item in items if not item.get_closest_marker("early")]
    workers = int(getattr(config, "workerinput", {}).get("workercount", 1))
    runs = [[] for _ in range(workers)]
    for i, item in enumerate(early):
        runs[i % workers].append(item)
    left = len(items)
    start = 0
    for k, run in enumerate(runs):  # the sizes of xdist's first hand-out
        size = left // (workers - k)
        left -= size
        stop = max(start, start + size - len(run))
        run.extend(rest[start:stop])
        start = stop
    runs[-1].extend(rest[start:])
    items[:] = [item for run in runs for item in run]
