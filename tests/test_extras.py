"""The small core: optional layers import their dependency when used, refuse in one line."""

import subprocess
import sys
import tomllib
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from dcstereo import _extras
from dcstereo.cli import main
from dcstereo.evaluation import downloads as datasets
from dcstereo.viz import colorize

ROOT = Path(__file__).resolve().parents[1]
OPTIONAL = ("distributed", "dask", "imageio_ffmpeg", "matplotlib", "pooch", "cv2", "rerun")


def test_the_core_dependencies_are_the_kernels_images_and_the_command_line():
    project = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
    names = {
        dep.split(">")[0].split("=")[0].split("<")[0].strip() for dep in project["dependencies"]
    }
    assert names == {"numpy", "numba", "llvmlite", "pillow", "click", "rich"}
    extras = project["optional-dependencies"]
    for extra, package in (
        ("dask", "distributed"),
        ("video", "imageio-ffmpeg"),
        ("plot", "matplotlib"),
        ("data", "pooch"),
        ("opencv", "opencv-python-headless"),
    ):
        assert any(dep.startswith(package) for dep in extras[extra]), extra


def test_importing_the_library_and_the_cli_imports_no_optional_layer():
    code = (
        "import sys, dcstereo, dcstereo.cli, dcstereo.batch, dcstereo.viz, dcstereo.evaluation; "
        f"print(sorted(m for m in {OPTIONAL!r} if m in sys.modules))"
    )
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert done.stdout.strip() == "[]"


@pytest.fixture
def without(monkeypatch):
    """Make ``import NAME`` fail, as when the package is not installed."""

    def hide(name):
        monkeypatch.setitem(sys.modules, name, None)

    return hide


def test_require_names_the_extra(without):
    without("matplotlib")
    with pytest.raises(
        _extras.MissingExtraError, match=r"'plot' extra: pip install \"dcstereo\[plot\]\""
    ):
        _extras.require("matplotlib", "plot", "colour maps")


def test_colour_maps_without_matplotlib_name_the_plot_extra(without):
    without("matplotlib")
    with pytest.raises(ImportError, match=r"dcstereo\[plot\]"):
        colorize(np.zeros((2, 2), dtype=np.float32))


def test_downloads_without_pooch_name_the_data_extra(without, monkeypatch):
    without("pooch")
    monkeypatch.delenv(datasets.CACHE_ENV_VAR, raising=False)
    with pytest.raises(ImportError, match=r"dcstereo\[data\]"):
        datasets.default_cache_dir()


def test_video_files_without_ffmpeg_name_the_video_extra(without):
    from dcstereo.batch import video

    without("imageio_ffmpeg")
    with pytest.raises(ImportError, match=r"dcstereo\[video\]"):
        video._ffmpeg()


def test_cli_without_dask_is_one_line_naming_the_extra(without, tmp_path):
    without("distributed")
    from PIL import Image

    pair = tmp_path / "in" / "pair"
    pair.mkdir(parents=True)
    texture = np.random.default_rng(0).integers(0, 256, (16, 24), dtype=np.uint8)
    for name in ("left.png", "right.png"):
        Image.fromarray(texture).save(pair / name)
    result = CliRunner().invoke(
        main,
        [
            "batch",
            str(tmp_path / "in"),
            "-o",
            str(tmp_path / "out"),
            "--max-disparity",
            "4",
            "--scheduler",
            "local:1",
        ],
    )
    assert result.exit_code != 0
    lines = [line for line in result.output.splitlines() if line.strip()]
    assert lines[-1].startswith("Error:") and "dcstereo[dask]" in lines[-1], result.output
    assert "Traceback" not in result.output
