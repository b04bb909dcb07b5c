"""``dcstereo rectify`` and ``dcstereo run --rectify`` through click's runner."""

import numpy as np
import pytest
from click.testing import CliRunner
from PIL import Image

from dcstereo import io
from dcstereo.cli import main
from dcstereo.geometry import Calibration
from test_rectification import Rig, textured_pair, write_filestorage

cv2 = pytest.importorskip("cv2")


def invoke(*args):
    return CliRunner().invoke(main, [str(a) for a in args], catch_exceptions=False)


@pytest.fixture
def rig_files(tmp_path):
    """An unrectified pair (camera 1 left) and its calibration as stereo.yml."""
    left, right, _ = textured_pair(5, 120, 200)
    rig = Rig(focal=220.0, cx=99.5, cy=59.5, baseline=60.0, size=(200, 120))
    Image.fromarray(rig.unrectify(left, 1)).save(tmp_path / "cam1.png")
    Image.fromarray(rig.unrectify(right, 2)).save(tmp_path / "cam2.png")
    c = rig.calibration()
    write_filestorage(
        tmp_path / "stereo.yml",
        {
            "K1": c.K1,
            "D1": c.D1,
            "K2": c.K2,
            "D2": c.D2,
            "R": c.R,
            "T": c.T,
            "image_size": np.array([200, 120]),
        },
    )
    return tmp_path, c


def test_rectify_writes_pair_and_calib_for_run(rig_files):
    folder, c = rig_files
    out = folder / "rect"
    result = invoke(
        "rectify", folder / "cam1.png", folder / "cam2.png", folder / "stereo.yml", "-o", out
    )
    assert result.exit_code == 0, result.output
    assert "baseline 60" in result.output
    assert sorted(p.name for p in out.iterdir()) == [
        "calib.txt",
        "left.png",
        "right.png",
        "valid.png",
    ]
    calibration = Calibration.from_middlebury(out / "calib.txt")
    assert calibration.baseline == pytest.approx(60.0, rel=1e-6)
    assert io.read_image(out / "left.png").shape == (120, 200)
    # run --calib on the written pair, and run --rectify in one go: the same depth
    a = invoke(
        "run",
        out / "left.png",
        out / "right.png",
        "-o",
        folder / "a.pfm",
        "-q",
        "--max-disparity",
        40,
        "--calib",
        out / "calib.txt",
        "--depth-out",
        folder / "a_depth.pfm",
    )
    assert a.exit_code == 0, a.output
    b = invoke(
        "run",
        folder / "cam1.png",
        folder / "cam2.png",
        "-o",
        folder / "b.pfm",
        "-q",
        "--max-disparity",
        40,
        "--rectify",
        folder / "stereo.yml",
        "--depth-out",
        folder / "b_depth.pfm",
    )
    assert b.exit_code == 0, b.output
    np.testing.assert_array_equal(
        io.read_disparity(folder / "a.pfm"), io.read_disparity(folder / "b.pfm")
    )
    depth_a = io.read_depth(folder / "a_depth.pfm")
    depth_b = io.read_depth(folder / "b_depth.pfm")
    np.testing.assert_allclose(depth_a, depth_b, rtol=1e-5)
    # the scene is a plane at depth f * B / d: about 220 * 60 / 20 = 660 in the middle
    assert 400 < np.nanmedian(depth_b) < 1000


def test_rectify_middlebury_calib_copies(tmp_path, pair):
    folder, _ = pair
    (folder / "calib.txt").write_text(
        "cam0=[300 0 31.5; 0 300 11.5; 0 0 1]\ncam1=[300 0 31.5; 0 300 11.5; 0 0 1]\n"
        "doffs=0\nbaseline=100\nwidth=64\nheight=24\n"
    )
    result = invoke(
        "rectify",
        folder / "left.png",
        folder / "right.png",
        folder / "calib.txt",
        "-o",
        folder / "out",
        "-q",
    )
    assert result.exit_code == 0, result.output
    np.testing.assert_array_equal(
        io.read_image(folder / "out" / "left.png"), io.read_image(folder / "left.png")
    )


@pytest.mark.parametrize(
    "change, message",
    [
        ({"T": None}, "lacks T"),
        ({"K1": np.eye(2)}, "K1 must be a 3x3 matrix"),
        ({"K2": np.zeros((3, 3))}, "K2 cannot be inverted"),
        ({"image_size": np.array([320, 240])}, "for 320x240 images but the pair is 200x120"),
    ],
)
def test_rectify_bad_calibration_one_line_nothing_written(rig_files, change, message):
    folder, c = rig_files
    entries = {"K1": c.K1, "D1": c.D1, "K2": c.K2, "D2": c.D2, "R": c.R, "T": c.T}
    entries.update(change)
    write_filestorage(folder / "bad.yml", {k: v for k, v in entries.items() if v is not None})
    for args in (
        [
            "rectify",
            folder / "cam1.png",
            folder / "cam2.png",
            folder / "bad.yml",
            "-o",
            folder / "out",
        ],
        [
            "run",
            folder / "cam1.png",
            folder / "cam2.png",
            "-o",
            folder / "d.pfm",
            "--rectify",
            folder / "bad.yml",
            "--max-disparity",
            40,
        ],
    ):
        result = invoke(*args)
        assert result.exit_code == 1
        assert message in result.output
        assert len(result.output.strip().splitlines()) == 1 and "Traceback" not in result.output
    assert not (folder / "out").exists() and not (folder / "d.pfm").exists()


def test_rectify_failed_write_leaves_nothing(rig_files, refuse_move):
    folder, _ = rig_files
    refuse_move("calib.txt")
    result = invoke(
        "rectify",
        folder / "cam1.png",
        folder / "cam2.png",
        folder / "stereo.yml",
        "-o",
        folder / "out",
    )
    assert result.exit_code == 1 and "permission denied" in result.output
    assert not (folder / "out").exists()


def test_run_rectify_with_calib_refused(rig_files):
    folder, _ = rig_files
    result = invoke(
        "run",
        folder / "cam1.png",
        folder / "cam2.png",
        "-o",
        folder / "d.pfm",
        "--rectify",
        folder / "stereo.yml",
        "--calib",
        folder / "x.txt",
        "--depth-out",
        folder / "z.pfm",
        "--max-disparity",
        40,
    )
    assert result.exit_code == 1 and "--rectify gives the calibration" in result.output


def test_rectify_without_opencv_names_the_extra(rig_files, monkeypatch):
    import builtins

    real = builtins.__import__

    def no_cv2(name, *args, **kwargs):
        if name == "cv2":
            raise ImportError("No module named 'cv2'")
        return real(name, *args, **kwargs)

    monkeypatch.setattr(builtins, "__import__", no_cv2)
    folder, _ = rig_files
    result = CliRunner().invoke(
        main,
        [
            str(a)
            for a in (
                "rectify",
                folder / "cam1.png",
                folder / "cam2.png",
                folder / "stereo.yml",
                "-o",
                folder / "out",
            )
        ],
    )
    assert result.exit_code == 1
    assert "dcstereo[opencv]" in result.output and "Traceback" not in result.output
