"""The Python examples of the guide pages run, and print what the pages show."""

import re
import subprocess
import sys
from pathlib import Path

import pytest

GUIDE = Path(__file__).resolve().parents[1] / "docs" / "guide"


def blocks(page):
    """The fenced blocks of a page: ``[(language, text), ...]`` in order."""
    text = (GUIDE / page).read_text(encoding="utf-8")
    return re.findall(r"^```(\w*)\n(.*?)^```", text, flags=re.S | re.M)


def run_python(code, cwd):
    done = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, cwd=cwd, check=False
    )
    assert done.returncode == 0, done.stderr
    return done.stdout


def test_opencv_page_example_runs_and_prints_what_it_shows(tmp_path):
    pytest.importorskip("cv2")
    pytest.importorskip("skimage")
    found = blocks("opencv.md")
    index = next(i for i, (language, _) in enumerate(found) if language == "python")
    output = run_python(found[index][1], tmp_path)
    assert found[index + 1][0] == ""  # the output block right after it
    assert output.strip() == found[index + 1][1].strip()


def test_rerun_page_examples_run(tmp_path):
    pytest.importorskip("rerun")
    pytest.importorskip("skimage")
    code = "\n".join(text for language, text in blocks("rerun.md") if language == "python")
    output = run_python(code, tmp_path)
    assert (tmp_path / "motorcycle.rrd").is_file()
    assert "/world/points" in output and "/disparity" in output
