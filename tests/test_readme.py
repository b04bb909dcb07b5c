"""The README's Python examples run as written, on a small synthetic pair.

A user copies them: each ``python`` block of the README that works on files runs here, in
order and in one namespace (later blocks use the names earlier ones made), in a folder with
the files they name. The last block needs a Dask scheduler at a made-up address and is
only checked to be there.
"""

import re
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

import synthetic
from dcstereo import io
from test_geometry import MOTORCYCLE_CALIB

README = Path(__file__).resolve().parents[1] / "README.md"


def python_blocks():
    return re.findall(r"```python\n(.*?)```", README.read_text(encoding="utf-8"), re.S)


def test_the_readme_has_its_python_examples():
    blocks = python_blocks()
    assert len(blocks) >= 5
    assert 'Client("tcp://scheduler:8786")' in blocks[-1]  # the one not run


def test_the_readme_python_examples_run(tmp_path, monkeypatch):
    rng = np.random.default_rng(3)
    left, right = synthetic.constant_pair(rng, 40, 160, 12)
    Image.fromarray(left).save(tmp_path / "left.png")
    Image.fromarray(right).save(tmp_path / "right.png")
    (tmp_path / "calib.txt").write_text(MOTORCYCLE_CALIB)
    monkeypatch.chdir(tmp_path)
    namespace: dict = {}
    blocks = python_blocks()[:-1]
    for number, block in enumerate(blocks):
        try:
            exec(compile(block, f"README python block {number}", "exec"), namespace)
        except Exception as exc:  # name the block, not just the line
            pytest.fail(f"README python block {number} fails: {type(exc).__name__}: {exc}")
    # what the blocks wrote is what they say
    disparity = io.read_pfm(tmp_path / "disparity.pfm")
    assert np.nanmedian(disparity[:, 20:]) == 12
    assert (tmp_path / "cloud.ply").stat().st_size > 0
    depth_png = io.read_depth(tmp_path / "depth.png")
    depth_pfm = io.read_depth(tmp_path / "depth.pfm")
    known = np.isfinite(depth_pfm)
    assert known.any() and np.array_equal(np.isfinite(depth_png), known)
    assert np.abs(depth_png[known] - depth_pfm[known]).max() <= 0.5
    assert namespace["kept"].shape == left.shape


def test_the_readme_says_why_each_dependency_is_there():
    # every package pyproject.toml installs (extras included) has a row in the README's
    # "Dependencies, and why" table
    import tomllib

    project = tomllib.loads((README.parent / "pyproject.toml").read_text(encoding="utf-8"))
    wanted = list(project["project"]["dependencies"])
    for extra in project["project"]["optional-dependencies"].values():
        wanted += extra
    names = {re.split(r"[<>=!~\[; ]", spec, maxsplit=1)[0].lower() for spec in wanted}
    text = README.read_text(encoding="utf-8")
    table = text.split("## Dependencies, and why", 1)[1].split("\n## ", 1)[0]
    named = {
        word.lower()
        for line in table.splitlines()
        if line.startswith("| ")
        for word in re.findall(r"[A-Za-z][\w.-]*", line.split("|")[1])
    }
    assert names <= named, sorted(names - named)
