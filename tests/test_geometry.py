"""Depth and point clouds (``dcstereo.geometry``), the PLY writer, and their CLI options."""

import numpy as np
import pytest
from PIL import Image

from dcstereo import io, match
from dcstereo.evaluation import datasets
from dcstereo.geometry import Calibration, depth, point_cloud, read_calib
from test_cli import invoke

#: Middlebury 2014 Motorcycle's calib.txt, as published.
MOTORCYCLE_CALIB = """cam0=[3979.911 0 1244.772; 0 3979.911 1019.507; 0 0 1]
cam1=[3979.911 0 1369.115; 0 3979.911 1019.507; 0 0 1]
doffs=124.343
baseline=193.001
width=2964
height=1988
ndisp=270
isint=0
vmin=23
vmax=245
dyavg=0
dymax=0
"""


def read_ply(path):
    """A plain reader of the binary little-endian PLY files ``io.write_ply`` makes."""
    data = path.read_bytes()
    end = data.index(b"end_header\n") + len(b"end_header\n")
    header = data[:end].decode("ascii").splitlines()
    assert header[:2] == ["ply", "format binary_little_endian 1.0"]
    count = next(int(line.split()[2]) for line in header if line.startswith("element vertex"))
    kinds = {"float": "<f4", "uchar": "u1"}
    fields = [
        (line.split()[2], kinds[line.split()[1]]) for line in header if line.startswith("property")
    ]
    vertices = np.frombuffer(data, dtype=fields, count=count, offset=end)
    assert end + vertices.nbytes == len(data)  # nothing after the vertices
    return header, vertices


# --------------------------------------------------------------------------- Calibration


def test_calibration_checks_its_values():
    c = Calibration(np.float32(500), 100, 10.5, np.int64(7))
    assert (c.focal, c.baseline, c.cx, c.cy, c.doffs, c.fy) == (500, 100, 10.5, 7, 0, 500)
    assert type(c.cy) is float
    assert Calibration(500, 100, 0, 0, focal_y=510).fy == 510
    for kwargs, error, message in [
        (dict(focal=0), ValueError, "focal must be positive, got 0"),
        (dict(baseline=-1), ValueError, "baseline must be positive, got -1"),
        (dict(focal_y=0), ValueError, "focal_y must be positive"),
        (dict(cx=np.nan), ValueError, "cx must be finite"),
        (dict(doffs=np.inf), ValueError, "doffs must be finite"),
        (dict(cy="1"), TypeError, "cy must be a number, got str"),
        (dict(focal=True), TypeError, "focal must be a number, got bool"),
    ]:
        values = dict(focal=500, baseline=100, cx=0, cy=0) | kwargs
        with pytest.raises(error, match=message):
            Calibration(**values)


def test_middlebury_calib_file(tmp_path):
    path = tmp_path / "calib.txt"
    path.write_text(MOTORCYCLE_CALIB)
    c = Calibration.from_middlebury(path)
    assert (c.focal, c.fy, c.cx, c.cy) == (3979.911, 3979.911, 1244.772, 1019.507)
    assert (c.baseline, c.doffs) == (193.001, 124.343)
    assert read_calib(path)["ndisp"] == "270"
    # without doffs: cam1's cx less cam0's; without cam1 either: 0
    path.write_text(MOTORCYCLE_CALIB.replace("doffs=124.343\n", ""))
    assert Calibration.from_middlebury(path).doffs == pytest.approx(1369.115 - 1244.772)
    path.write_text("cam0=[400 0 20; 0 410 30; 0 0 1]\nbaseline=50\n")
    c = Calibration.from_middlebury(path)
    assert (c.focal, c.fy, c.cx, c.cy, c.baseline, c.doffs) == (400, 410, 20, 30, 50, 0)


@pytest.mark.parametrize(
    "text, message",
    [
        ("baseline=5\n", "lacks 'cam0='"),
        ("cam0=[1 0 0; 0 1 0; 0 0 1]\n", "lacks 'baseline='"),
        ("cam0=1 0 0; 0 1 0; 0 0 1\nbaseline=5\n", "cam0 must be a matrix"),
        ("cam0=[1 0 0; 0 1 0]\nbaseline=5\n", "cam0 must be a 3 x 3 matrix"),
        ("cam0=[1 0 x; 0 1 0; 0 0 1]\nbaseline=5\n", "cam0 is not a number: 'x'"),
        ("cam0=[1 0 0; 0 1 0; 0 0 1]\nbaseline=five\n", "baseline is not a number"),
        ("cam0=[1 0 0; 0 1 0; 0 0 1]\nbaseline=nan\n", "baseline must be finite"),
        ("cam0=[0 0 0; 0 1 0; 0 0 1]\nbaseline=5\n", "focal must be positive"),
        ("cam0=[1 0 0; 0 1 0; 0 0 1]\nbaseline=5\ndoffs=?\n", "doffs is not a number"),
    ],
)
def test_middlebury_calib_errors_name_the_file(tmp_path, text, message):
    path = tmp_path / "calib.txt"
    path.write_text(text)
    with pytest.raises(ValueError, match=message) as info:
        Calibration.from_middlebury(path)
    assert str(path) in str(info.value) and "\n" not in str(info.value)


def test_calib_file_that_cannot_be_read(tmp_path):
    with pytest.raises(ValueError, match="file does not exist"):
        Calibration.from_middlebury(tmp_path / "missing.txt")
    with pytest.raises(ValueError, match="not a regular file"):
        Calibration.from_middlebury(tmp_path)
    (tmp_path / "bad.txt").write_bytes(b"\xff\xfecam0=\n")
    with pytest.raises(ValueError, match="not UTF-8 text"):
        Calibration.from_middlebury(tmp_path / "bad.txt")


# --------------------------------------------------------------------------- depth


def test_depth_by_hand():
    c = Calibration(focal=100, baseline=50, cx=0, cy=0, doffs=2)
    d = np.array([[8.0, 3.0, np.nan], [-2.0, -5.0, np.inf]])
    z = depth(d, c)
    assert z.dtype == np.float32 and z.shape == d.shape
    # 50 * 100 / (8 + 2) and / (3 + 2); the rest: no estimate, or at or beyond infinity
    np.testing.assert_array_equal(z, [[500.0, 1000.0, np.nan], [np.nan, np.nan, np.nan]])
    # a depth beyond float32's range is no depth either
    assert np.isnan(depth(np.array([[1e-300]]), Calibration(1e10, 1e10, 0, 0)))[0, 0]
    # integer disparities are accepted
    assert depth(np.array([[8]]), c)[0, 0] == 500.0


def test_depth_refuses_bad_input():
    c = Calibration(100, 50, 0, 0)
    with pytest.raises(ValueError, match=r"disparity must be 2-D \(H, W\), got shape \(3,\)"):
        depth(np.ones(3), c)
    with pytest.raises(TypeError, match="disparity must hold real numbers, got dtype complex"):
        depth(np.ones((2, 2), complex), c)
    with pytest.raises(TypeError, match="calibration must be a dcstereo.geometry.Calibration"):
        depth(np.ones((2, 2)), (100, 50))


# --------------------------------------------------------------------------- point clouds


def slow_point_cloud(disparity, c):
    """Every pixel with a positive ``d + doffs``, one at a time, by the pinhole formulas."""
    points, pixels = [], []
    for y in range(disparity.shape[0]):
        for x in range(disparity.shape[1]):
            d = float(disparity[y, x])
            if not np.isfinite(d) or d + c.doffs <= 0:
                continue
            z = c.baseline * c.focal / (d + c.doffs)
            points.append(((x - c.cx) * z / c.focal, (y - c.cy) * z / c.fy, z))
            pixels.append((y, x))
    return np.array(points).reshape(-1, 3), np.array(pixels).reshape(-1, 2)


def test_point_cloud_equals_the_pinhole_formulas():
    rng = np.random.default_rng(3)
    d = rng.uniform(-1, 30, (7, 9))
    d[rng.random(d.shape) < 0.2] = np.nan
    c = Calibration(focal=420, baseline=60, cx=4.5, cy=2.25, doffs=0.5, focal_y=430)
    cloud = point_cloud(d, c)
    points, pixels = slow_point_cloud(d, c)
    assert len(cloud) == len(points) > 30
    np.testing.assert_array_equal(cloud.pixels, pixels)
    np.testing.assert_allclose(cloud.points, points, rtol=1e-6)
    assert cloud.points.dtype == np.float32 and cloud.colors is None
    # the points project back onto their pixels, and their depth is depth()'s
    x, y, z = cloud.points.astype(np.float64).T
    np.testing.assert_allclose(c.focal * x / z + c.cx, pixels[:, 1], atol=1e-4)
    np.testing.assert_allclose(c.fy * y / z + c.cy, pixels[:, 0], atol=1e-4)
    np.testing.assert_array_equal(cloud.points[:, 2], depth(d, c)[pixels[:, 0], pixels[:, 1]])


def test_point_cloud_of_a_fronto_parallel_plane():
    # constant disparity: one depth, and the points' spacing is depth / focal
    c = Calibration(focal=200, baseline=40, cx=3, cy=1)
    cloud = point_cloud(np.full((3, 7), 8.0), c)
    assert len(cloud) == 21
    np.testing.assert_array_equal(cloud.points[:, 2], 1000.0)
    np.testing.assert_allclose(np.diff(cloud.points[:7, 0]), 5.0)
    np.testing.assert_allclose(cloud.points[cloud.pixels[:, 0] == 1, 1], 0.0)


def test_point_cloud_colours_mask_and_range():
    c = Calibration(focal=100, baseline=10, cx=0, cy=0)
    d = np.array([[10.0, 5.0], [np.nan, 1.0]])  # depths 100, 200, -, 1000
    rgb = np.arange(12, dtype=np.uint8).reshape(2, 2, 3)
    cloud = point_cloud(d, c, rgb)
    np.testing.assert_array_equal(cloud.colors, rgb.reshape(-1, 3)[[0, 1, 3]])
    gray = np.array([[1, 2], [3, 4]], np.uint8)
    np.testing.assert_array_equal(point_cloud(d, c, gray).colors[:, 1], [1, 2, 4])
    wide = np.array([[0x1234, 0xFFFF], [0, 0x0100]], np.uint16)
    np.testing.assert_array_equal(point_cloud(d, c, wide).colors[:, 2], [0x12, 0xFF, 0x01])
    mask = np.array([[False, True], [True, True]])
    np.testing.assert_array_equal(point_cloud(d, c, mask=mask).pixels, [[0, 1], [1, 1]])
    np.testing.assert_array_equal(point_cloud(d, c, max_depth=200).pixels, [[0, 0], [0, 1]])
    assert len(point_cloud(np.full((2, 2), np.nan), c)) == 0


def test_point_cloud_refuses_bad_arguments():
    c = Calibration(100, 10, 0, 0)
    d = np.ones((2, 3))
    with pytest.raises(ValueError, match=r"image must have shape \(2, 3\) or \(2, 3, 3\)"):
        point_cloud(d, c, np.zeros((3, 2), np.uint8))
    with pytest.raises(ValueError, match="image must have shape"):
        point_cloud(d, c, np.zeros((2, 3, 4), np.uint8))
    with pytest.raises(TypeError, match="image must be uint8 or uint16"):
        point_cloud(d, c, np.zeros((2, 3)))
    with pytest.raises(ValueError, match="mask must be a bool array of shape"):
        point_cloud(d, c, mask=np.ones((2, 3), int))
    with pytest.raises(ValueError, match="max_depth must be a positive number"):
        point_cloud(d, c, max_depth=0)


# --------------------------------------------------------------------------- PLY


def test_ply_round_trip(tmp_path):
    rng = np.random.default_rng(5)
    points = rng.normal(size=(50, 3)) * 1000
    colors = rng.integers(0, 256, (50, 3), dtype=np.uint8)
    io.write_ply(tmp_path / "c.ply", points, colors)
    header, vertices = read_ply(tmp_path / "c.ply")
    assert header == [
        "ply",
        "format binary_little_endian 1.0",
        "comment written by dcstereo",
        "element vertex 50",
        "property float x",
        "property float y",
        "property float z",
        "property uchar red",
        "property uchar green",
        "property uchar blue",
        "end_header",
    ]
    for axis, name in enumerate("xyz"):
        np.testing.assert_array_equal(vertices[name], points[:, axis].astype(np.float32))
    for channel, name in enumerate(("red", "green", "blue")):
        np.testing.assert_array_equal(vertices[name], colors[:, channel])


def test_ply_without_colours_and_empty(tmp_path):
    io.write_ply(tmp_path / "a.ply", np.ones((2, 3), np.float32))
    header, vertices = read_ply(tmp_path / "a.ply")
    assert "property uchar red" not in header and vertices.dtype.names == ("x", "y", "z")
    io.write_ply(tmp_path / "b.ply", np.empty((0, 3)), np.empty((0, 3), np.uint8))
    header, vertices = read_ply(tmp_path / "b.ply")
    assert "element vertex 0" in header and len(vertices) == 0


@pytest.mark.parametrize(
    "points, colors, error, message",
    [
        (np.ones((4, 2)), None, ValueError, r"points must have shape \(N, 3\), got \(4, 2\)"),
        (np.array([[1, np.nan, 0]]), None, ValueError, "points must be finite"),
        (np.array([[1e300, 0, 0]]), None, ValueError, "points must be finite"),
        (np.ones((2, 3), complex), None, TypeError, "points must hold real numbers"),
        (np.ones((2, 3)), np.ones((2, 3)), TypeError, "colors must be uint8"),
        (np.ones((2, 3)), np.ones((3, 3), np.uint8), ValueError, r"colors must have shape"),
    ],
)
def test_ply_refuses_bad_input_and_writes_nothing(tmp_path, points, colors, error, message):
    with pytest.raises(error, match=message):
        io.write_ply(tmp_path / "c.ply", points, colors)
    assert list(tmp_path.iterdir()) == []


# --------------------------------------------------------------------------- scenes


def test_scenes_carry_their_calibration(tmp_path):
    from test_datasets import write_2014_scene

    write_2014_scene(tmp_path / "a")
    (tmp_path / "a" / "calib.txt").write_text(MOTORCYCLE_CALIB.replace("ndisp=270", "ndisp=8"))
    scene = datasets.load_scene(tmp_path / "a")
    assert scene.calibration == Calibration.from_middlebury(tmp_path / "a" / "calib.txt")
    (tmp_path / "a" / "calib.txt").write_text("ndisp=8\n")  # no geometry: None
    assert datasets.load_scene(tmp_path / "a").calibration is None
    (tmp_path / "a" / "calib.txt").write_text("ndisp=8\ncam0=[1 2]\nbaseline=3\n")
    with pytest.raises(ValueError, match=r"calib.txt': cam0 must be a 3 x 3 matrix"):
        datasets.load_scene(tmp_path / "a")
    with pytest.raises(TypeError, match="calibration must be a Calibration or None, got dict"):
        datasets.StereoScene(
            "x", np.zeros((2, 2)), np.zeros((2, 2)), np.zeros((2, 2)), {}, 4, calibration={}
        )


def test_motorcycle_calibration_is_scikit_images():
    pytest.importorskip("skimage")
    scene = datasets.load_motorcycle()
    c = scene.calibration
    # the 2014 calibration divided by 4, as scikit-image documents it
    assert c.focal == pytest.approx(3979.911 / 4, abs=1e-3)
    assert (c.cx, c.cy) == pytest.approx((1244.772 / 4, 1019.507 / 4), abs=1e-3)
    assert c.doffs == pytest.approx(124.343 / 4, abs=1e-3) and c.baseline == 193.001
    # the ground truth's depths: the motorcycle stands two to five metres away
    z = depth(scene.disparity, c)
    assert 1800 < np.nanmin(z) and np.nanmax(z) < 5500


# --------------------------------------------------------------------------- CLI


def test_run_writes_depth_and_cloud(pair):
    folder, _ = pair
    left, right = io.read_image(folder / "left.png"), io.read_image(folder / "right.png")
    expected = match(left, right, max_disparity=10).disparity
    c = Calibration(focal=300, baseline=80, cx=31.5, cy=11.5)  # the image centre
    result = invoke(
        "run", folder / "left.png", folder / "right.png", "-o", folder / "d.pfm",
        "--max-disparity", 10, "--depth-out", folder / "z.pfm", "--ply", folder / "c.ply",
        "--focal", 300, "--baseline", 80, "-q",
    )  # fmt: skip
    assert result.exit_code == 0, result.output
    np.testing.assert_array_equal(
        np.nan_to_num(io.read_pfm(folder / "z.pfm"), posinf=-1),
        np.nan_to_num(depth(expected, c), nan=-1),
    )
    _, vertices = read_ply(folder / "c.ply")
    cloud = point_cloud(expected, c, left)
    np.testing.assert_array_equal(np.stack([vertices[a] for a in "xyz"], 1), cloud.points)
    np.testing.assert_array_equal(vertices["red"], cloud.colors[:, 0])
    # a calib.txt gives the same geometry as the options
    (folder / "calib.txt").write_text("cam0=[300 0 31.5; 0 300 11.5; 0 0 1]\nbaseline=80\n")
    result = invoke(
        "run", folder / "left.png", folder / "right.png", "-o", folder / "d2.pfm",
        "--max-disparity", 10, "--ply", folder / "c2.ply", "--calib", folder / "calib.txt",
    )  # fmt: skip
    assert result.exit_code == 0, result.output
    assert (folder / "c2.ply").read_bytes() == (folder / "c.ply").read_bytes()
    assert result.output.splitlines()[1] == f"{len(cloud)} points -> {folder / 'c2.ply'}"
    # --principal and --doffs
    result = invoke(
        "run", folder / "left.png", folder / "right.png", "-o", folder / "d3.pfm",
        "--max-disparity", 10, "--depth-out", folder / "z3.pfm", "--focal", 300,
        "--baseline", 80, "--principal", 0, 0, "--doffs", 2,
    )  # fmt: skip
    assert result.exit_code == 0, result.output
    shifted = depth(expected, Calibration(300, 80, 0, 0, doffs=2))
    z3 = io.read_pfm(folder / "z3.pfm")
    np.testing.assert_array_equal(np.isfinite(z3), np.isfinite(shifted))
    np.testing.assert_array_equal(z3[np.isfinite(z3)], shifted[np.isfinite(shifted)])


def test_run_writes_depth_png(pair):
    folder, _ = pair
    left, right = io.read_image(folder / "left.png"), io.read_image(folder / "right.png")
    expected = match(left, right, max_disparity=10).disparity
    z = depth(expected, Calibration(focal=300, baseline=80, cx=31.5, cy=11.5)).astype(float)
    result = invoke(
        "run", folder / "left.png", folder / "right.png", "-o", folder / "d.pfm",
        "--max-disparity", 10, "--depth-out", folder / "z.png", "--focal", 300,
        "--baseline", 80,
    )  # fmt: skip
    assert result.exit_code == 0, result.output
    assert len(result.output.splitlines()) == 1  # every depth fits: nothing left out
    stored = np.asarray(Image.open(folder / "z.png"))
    assert stored.dtype == np.uint16 and np.isfinite(z).any()
    np.testing.assert_array_equal(stored, np.where(np.isfinite(z), np.rint(z), 0))
    # at 10 per unit the far pixels (d < 24000 * 10 / 65535.5) no longer fit: left out, said
    result = invoke(
        "run", folder / "left.png", folder / "right.png", "-o", folder / "d.pfm",
        "--max-disparity", 10, "--depth-out", folder / "z10.png", "--depth-scale", 10,
        "--focal", 300, "--baseline", 80,
    )  # fmt: skip
    assert result.exit_code == 0, result.output
    far = np.isfinite(z) & (np.rint(z * 10) > 65535)
    assert far.any() and (np.isfinite(z) & ~far).any()
    assert result.output.splitlines()[1] == (
        f"{far.sum()} pixels too far for 16 bits left out of {folder / 'z10.png'}"
    )
    back = io.read_depth(folder / "z10.png", scale=10)
    kept = np.isfinite(z) & ~far
    np.testing.assert_array_equal(np.isfinite(back), kept)
    np.testing.assert_allclose(back[kept], z[kept], atol=0.05 + 1e-6)


@pytest.mark.parametrize(
    "args, message",
    [
        (["--ply", "c.ply"], "--depth-out and --ply need a calibration: --calib FILE, or "
         "--focal and --baseline (missing --focal)"),
        (["--depth-out", "z.pfm", "--focal", 9], "(missing --baseline)"),
        (["--focal", 9, "--baseline", 1],
         "--focal is used only with --depth-out, --ply or --rerun"),
        (["--ply", "c.ply", "--calib", "calib.txt", "--focal", 9],
         "--calib and --focal cannot be used together"),
        (["--ply", "c.ply", "--calib", "missing.txt"], "missing.txt: file does not exist"),
        (["--ply", "c.ply", "--calib", "left.png"], "not UTF-8 text"),
        (["--ply", "c.ply", "--focal", -3, "--baseline", 1], "focal must be positive, got -3"),
        (["--ply", "c.pcd", "--focal", 9, "--baseline", 1],
         "cannot write --ply 'c.pcd': unsupported suffix '.pcd', use .ply"),
        (["--depth-out", "z.tif", "--focal", 9, "--baseline", 1],
         "cannot write --depth-out 'z.tif': unsupported suffix '.tif', use one of .pfm, .png"),
        (["--depth-out", "z.pfm", "--depth-scale", 10, "--focal", 9, "--baseline", 1],
         "--depth-scale is used only with a .png --depth-out"),
        (["--depth-scale", 10], "--depth-scale is used only with a .png --depth-out"),
        (["--depth-out", "z.png", "--depth-scale", 0, "--focal", 9, "--baseline", 1],
         "--depth-scale must be a positive number, got 0"),
        (["--depth-out", "z.png", "--depth-scale", "nan", "--focal", 9, "--baseline", 1],
         "--depth-scale must be a positive number, got nan"),
        (["--ply", "calib.txt", "--calib", "calib.txt"], "--ply 'calib.txt' is --calib"),
        (["--ply", "c.ply", "--depth-out", "c.ply", "--focal", 9, "--baseline", 1],
         "--ply and --depth-out are the same file"),
    ],
)  # fmt: skip
def test_run_calibration_errors_are_one_line_and_write_nothing(pair, monkeypatch, args, message):
    folder, _ = pair
    (folder / "calib.txt").write_text("cam0=[300 0 31.5; 0 300 11.5; 0 0 1]\nbaseline=80\n")
    before = sorted(folder.iterdir())
    monkeypatch.chdir(folder)
    result = invoke("run", "left.png", "right.png", "-o", "d.pfm", "--max-disparity", 10, *args)
    assert result.exit_code == 1, result.output
    lines = result.output.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("Error: ") and message in lines[0], lines
    assert sorted(folder.iterdir()) == before
