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


def test_your_rig_page_examples_run(tmp_path):
    """your-rig.md: the calibration and rectification blocks print what the page shows,
    and its first command-line block runs on the files they made."""
    pytest.importorskip("cv2")
    pytest.importorskip("skimage")
    found = blocks("your-rig.md")
    python = [i for i, (language, _) in enumerate(found) if language == "python"]
    run_python(found[python[0]][1], tmp_path)
    output = run_python(found[python[1]][1], tmp_path)
    assert found[python[1] + 1][0] == ""
    assert output.strip() == found[python[1] + 1][1].strip()
    from click.testing import CliRunner

    from dcstereo.cli import main

    commands = next(text for language, text in found if language == "bash")
    with pytest.MonkeyPatch.context() as patch:
        patch.chdir(tmp_path)
        for line in commands.strip().splitlines():
            args = line.split()
            assert args[0] == "dcstereo"
            result = CliRunner().invoke(main, args[1:], catch_exceptions=False)
            assert result.exit_code == 0, (line, result.output)
    assert (tmp_path / "rectified" / "calib.txt").is_file()
    assert (tmp_path / "depth.pfm").is_file() and (tmp_path / "depth2.pfm").is_file()
