"""The README's Python example runs as written, on a small synthetic pair.

A user copies it: each ``python`` block of the README runs here, in order and in one
namespace, in a folder with the files it names. (The documentation's examples run as
doctests: ``make doctest``.)
"""

import re
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

import synthetic
from dcstereo import io

ROOT = Path(__file__).resolve().parents[1]
README = ROOT / "README.md"
DEPENDENCIES = ROOT / "docs" / "dependencies.md"  # the documentation's "Dependencies, and why"


def python_blocks():
    return re.findall(r"```python\n(.*?)```", README.read_text(encoding="utf-8"), re.S)


def test_the_readme_has_its_python_example():
    assert python_blocks()


def test_the_readme_python_examples_run(tmp_path, monkeypatch):
    rng = np.random.default_rng(3)
    left, right = synthetic.constant_pair(rng, 40, 160, 12)
    Image.fromarray(left).save(tmp_path / "left.png")
    Image.fromarray(right).save(tmp_path / "right.png")
    monkeypatch.chdir(tmp_path)
    namespace: dict = {}
    blocks = python_blocks()
    for number, block in enumerate(blocks):
        try:
            exec(compile(block, f"README python block {number}", "exec"), namespace)
        except Exception as exc:  # name the block, not just the line
            pytest.fail(f"README python block {number} fails: {type(exc).__name__}: {exc}")
    # what the blocks wrote is what they say
    disparity = io.read_pfm(tmp_path / "disparity.pfm")
    assert np.nanmedian(disparity[:, 20:]) == 12


def test_the_docs_say_why_each_dependency_is_there():
    # every package pyproject.toml installs (extras included) has a row in the
    # documentation's "Dependencies, and why" table
    import tomllib

    project = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))
    wanted = list(project["project"]["dependencies"])
    for extra in project["project"]["optional-dependencies"].values():
        wanted += extra
    names = {re.split(r"[<>=!~\[; ]", spec, maxsplit=1)[0].lower() for spec in wanted}
    text = DEPENDENCIES.read_text(encoding="utf-8")
    table = text.split("# Dependencies, and why", 1)[1].split("\n## ", 1)[0]
    named = {
        word.lower()
        for line in table.splitlines()
        if line.startswith("| ")
        for word in re.findall(r"[A-Za-z][\w.-]*", line.split("|")[1])
    }
    assert names <= named, sorted(names - named)
