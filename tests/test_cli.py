"""The ``dcstereo`` command through click's test runner."""

import numpy as np
import pytest
from click.testing import CliRunner
from PIL import Image

from dcstereo import io
from dcstereo.cli import main


def invoke(*args):
    return CliRunner().invoke(main, [str(a) for a in args], catch_exceptions=False)


def test_run_writes_every_output(pair):
    folder, truth = pair
    out = folder / "disp.pfm"
    result = invoke(
        "run",
        folder / "left.png",
        folder / "right.png",
        "-o",
        out,
        "--max-disparity",
        10,
        "--occlusion-out",
        folder / "occ.png",
        "--preview",
        folder / "preview.png",
        "--features-out",
        folder / "features.csv",
        "--draw-features",
    )
    assert result.exit_code == 0, result.output
    assert "dc: 64x24" in result.output
    disparity = io.read_disparity(out)
    assert disparity.shape == (24, 64)
    scored = np.isfinite(truth) & np.isfinite(disparity)
    assert np.mean(np.abs(disparity[scored] - truth[scored]) <= 1) > 0.9
    occluded = io.read_image(folder / "occ.png")
    np.testing.assert_array_equal(occluded == 255, ~np.isfinite(disparity))
    assert io.read_image(folder / "preview.png").shape == (24, 64, 3)
    features = io.read_features_csv(folder / "features.csv")
    assert features.shape[1] == 5 and len(features) > 0
    rows, xl, xr = features[:, 0].astype(int), features[:, 1].astype(int), features[:, 2]
    np.testing.assert_array_equal(disparity[rows, xl], xl - xr)


def test_run_options_reach_the_matcher(pair):
    folder, _ = pair
    out = folder / "disp.png"
    result = invoke(
        "run",
        folder / "left.png",
        folder / "right.png",
        "-o",
        out,
        "--max-disparity",
        10,
        "--method",
        "dsi3",
        "--window",
        3,
        "--occlusion-cost",
        15,
        "--fill",
        "--threads",
        1,
        "--preview",
        folder / "p.png",
        "--preview-style",
        "color",
        "-q",
    )
    assert result.exit_code == 0, result.output
    assert result.output == ""
    disparity = io.read_disparity(out)
    assert np.isfinite(disparity).all()  # --fill gives a dense map
    assert io.read_image(folder / "p.png").shape == (24, 64, 3)


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (
            ["--max-disparity", 10, "-o", "{d}/x.pfm", "{d}/missing.png", "{d}/right.png"],
            "missing.png': file does not exist",
        ),
        (
            ["--max-disparity", 64, "-o", "{d}/x.pfm", "{d}/left.png", "{d}/right.png"],
            "max_disparity=64 does not fit an image 64 pixels wide",
        ),
        (
            ["--max-disparity", 10, "-o", "{d}/x.tif", "{d}/left.png", "{d}/right.png"],
            "unsupported suffix '.tif'",
        ),
        (
            ["--max-disparity", 10, "-o", "{d}/nodir/x.pfm", "{d}/left.png", "{d}/right.png"],
            "does not exist",
        ),
        (
            ["--max-disparity", 10, "-o", "{d}/x.pfm", "{d}/left.png", "{d}/small.png"],
            "differ in shape",
        ),
        (
            ["--max-disparity", 10, "-o", "{d}/x.pfm", "{d}/left.png", "{d}/notimage.png"],
            "not a recognised image format",
        ),
        (
            [
                "--max-disparity",
                10,
                "--window",
                4,
                "-o",
                "{d}/x.pfm",
                "{d}/left.png",
                "{d}/right.png",
            ],
            "window must be a positive odd integer",
        ),
        (
            [
                "--max-disparity",
                10,
                "--method",
                "dsi5",
                "--features-out",
                "{d}/f.csv",
                "-o",
                "{d}/x.pfm",
                "{d}/left.png",
                "{d}/right.png",
            ],
            "needs a method with features",
        ),
        (
            [
                "--max-disparity",
                3,
                "--min-disparity",
                5,
                "-o",
                "{d}/x.pfm",
                "{d}/left.png",
                "{d}/right.png",
            ],
            "min_disparity=5 is larger than max_disparity=3",
        ),
        (
            [
                "--max-disparity",
                10,
                "--threads",
                0,
                "-o",
                "{d}/x.pfm",
                "{d}/left.png",
                "{d}/right.png",
            ],
            "--threads must be between 1",
        ),
    ],
)
def test_run_errors_are_one_line_and_write_nothing(pair, args, message):
    folder, _ = pair
    Image.fromarray(np.zeros((24, 60), dtype=np.uint8)).save(folder / "small.png")
    (folder / "notimage.png").write_text("hello")
    before = set(folder.iterdir())
    result = invoke("run", *[str(a).format(d=folder) for a in args])
    assert result.exit_code == 1
    lines = result.output.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("Error: "), result.output
    assert message in lines[0]
    assert "Traceback" not in result.output
    assert set(folder.iterdir()) == before


def test_usage_errors_exit_2(pair):
    folder, _ = pair
    result = invoke("run", folder / "left.png", folder / "right.png", "-o", folder / "x.pfm")
    assert result.exit_code == 2
    assert "--max-disparity" in result.output


def test_version_and_help():
    assert invoke("--version").output.startswith("dcstereo, version")
    result = invoke("run", "--help")
    assert result.exit_code == 0 and "--occlusion-cost" in result.output


def test_demo_runs_on_the_motorcycle_pair(tmp_path):
    pytest.importorskip("skimage")
    out = tmp_path / "demo"
    result = invoke("demo", "--output", out, "--method", "dsi5", "--threads", 1)
    assert result.exit_code == 0, result.output
    assert "Motorcycle" in result.output and "bad-1.0" in result.output
    assert "depth of the dense map: median error" in result.output
    for name in ("disparity.pfm", "disparity.png", "occlusion.png", "preview.png"):
        assert (out / name).is_file()
    disparity = io.read_disparity(out / "disparity.pfm")
    assert disparity.shape == (500, 741)
    # depth and points of the written map, with the pair's calibration
    from dcstereo.datasets import MOTORCYCLE_CALIBRATION
    from dcstereo.geometry import depth

    z = io.read_pfm(out / "depth.pfm")
    expected = depth(disparity, MOTORCYCLE_CALIBRATION)
    np.testing.assert_array_equal(np.isfinite(z), np.isfinite(expected))
    assert (out / "cloud.ply").read_bytes().startswith(b"ply\nformat binary_little_endian")
    assert f"element vertex {np.isfinite(z).sum()}\n".encode() in (out / "cloud.ply").read_bytes()
    # the confidence of the sparse map, and its split into a surer and a less sure half
    from dcstereo import match
    from dcstereo.confidence import confidence
    from dcstereo.datasets import load_motorcycle

    scene = load_motorcycle()
    sparse = match(scene.left, scene.right, max_disparity=64, method="dsi5")
    sure = confidence(sparse, scene.left, scene.right)
    np.testing.assert_array_equal(
        io.read_pfm(out / "confidence.pfm"), np.nan_to_num(sure, nan=np.inf)
    )
    scored = scene.masks["all"] & np.isfinite(sparse.disparity) & np.isfinite(sure)
    bad = np.abs(sparse.disparity - scene.disparity)[scored] > 1.0
    surer = sure[scored] >= np.median(sure[scored])
    line = next(x for x in result.output.splitlines() if "confidence:" in x)
    assert line.endswith(
        f"bad-1.0 {100 * bad[surer].mean():.2f} %, the other half {100 * bad[~surer].mean():.2f} %"
    )
    assert bad[surer].mean() < bad[~surer].mean()


def test_demo_says_the_options_beyond_the_paper(tmp_path):
    pytest.importorskip("skimage")
    from dcstereo import match
    from dcstereo.datasets import load_motorcycle

    out = tmp_path / "demo"
    result = invoke("demo", "--output", out, "--method", "dsi5", "--median", 3, "--threads", 1)
    assert result.exit_code == 0, result.output
    assert "method dsi5, window 5, occlusion cost 10, median 3: " in result.output
    scene = load_motorcycle()
    expected = match(scene.left, scene.right, max_disparity=64, method="dsi5", median=3)
    np.testing.assert_array_equal(
        io.read_pfm(out / "disparity.pfm"), np.nan_to_num(expected.disparity, nan=np.inf)
    )


def test_demo_bad_option_makes_no_folder(tmp_path):
    pytest.importorskip("skimage")
    out = tmp_path / "demo"
    result = invoke("demo", "--output", out, "--max-disparity", -1, "--threads", 1)
    assert result.exit_code == 1
    assert result.output.strip().splitlines() == [
        "Error: min_disparity=0 is larger than max_disparity=-1"
    ]
    assert not out.exists()


@pytest.mark.parametrize("cost", ["sad", "bt"])
def test_run_cost_option_gives_the_library_result(pair, cost):
    import dcstereo

    folder, _ = pair
    out = folder / f"{cost}.pfm"
    args = ["run", folder / "left.png", folder / "right.png", "-o", out, "--max-disparity", 10]
    result = invoke(*args, "--method", "dsi5", "--cost", cost, "-q")
    assert result.exit_code == 0, result.output
    left, right = io.read_image(folder / "left.png"), io.read_image(folder / "right.png")
    expected = dcstereo.match(left, right, max_disparity=10, method="dsi5", cost=cost)
    np.testing.assert_array_equal(io.read_disparity(out), expected.disparity)


def test_run_unknown_cost_is_a_usage_error(pair):
    folder, _ = pair
    args = ["run", folder / "left.png", folder / "right.png", "-o", folder / "x.pfm"]
    result = invoke(*args, "--max-disparity", 10, "--cost", "ncc")
    assert result.exit_code == 2
    assert "'ncc' is not one of 'sad', 'bt'" in result.output
    assert not (folder / "x.pfm").exists()
