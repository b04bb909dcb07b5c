"""The ``dcstereo`` command through click's test runner."""

import numpy as np
import pytest
from click.testing import CliRunner
from PIL import Image

from dcstereo import io, params
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
        "--method",
        "dc",
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
    from dcstereo.evaluation.datasets import MOTORCYCLE_CALIBRATION
    from dcstereo.geometry import depth

    z = io.read_pfm(out / "depth.pfm")
    expected = depth(disparity, MOTORCYCLE_CALIBRATION)
    np.testing.assert_array_equal(np.isfinite(z), np.isfinite(expected))
    assert (out / "cloud.ply").read_bytes().startswith(b"ply\nformat binary_little_endian")
    assert f"element vertex {np.isfinite(z).sum()}\n".encode() in (out / "cloud.ply").read_bytes()
    # the confidence of the sparse map, and its split into a surer and a less sure half
    from dcstereo import match
    from dcstereo.evaluation.datasets import load_motorcycle
    from dcstereo.refine.confidence import confidence

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
    from dcstereo.evaluation.datasets import load_motorcycle

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


# The methods' own parameters: each flag, the method that reads it, the keyword of match()
# and the value it must arrive as.
METHOD_FLAGS = [
    ("dsi5", ["--slant-cost", "3"], {"slant_cost": 3.0}),
    ("dc", ["--slant-cost", "0"], {"slant_cost": 0.0}),
    ("dc", ["--ser-min", "20"], {"ser_min": 20.0}),
    ("dc", ["--vs-max", "0.05"], {"vs_max": 0.05}),
    ("dc", ["--vs-absolute", "--vs-max", "300"], {"vs_relative": False, "vs_max": 300.0}),
    ("dc-linear", ["--feature-floor", "400"], {"feature_floor": 400.0}),
    ("dc", ["--uniqueness", "0"], {"uniqueness": 0.0}),
    ("dc", ["--edge-guard", "0"], {"edge_guard": 0}),
    ("dc", ["--lr-check"], {"lr_check": True}),
    ("dc", ["--max-candidates", "3"], {"max_candidates": 3}),
    ("dsi3-gcp", ["--gcp-uniqueness", "1.5"], {"gcp_uniqueness": 1.5}),
    ("dsi3-gcp", ["--gcp-variance-floor", "25"], {"gcp_variance_floor": 25.0}),
    ("redert", ["--orientations=-0.25,0,0.25"], {"orientations": (-0.25, 0.0, 0.25)}),
    ("redert", ["--orientation-cost", "2"], {"orientation_cost": 2.0}),
    ("redert", ["--occlusion-discount", "0"], {"occlusion_discount": 0.0}),
    ("redert", ["--occlusion-discount-pixels", "2"], {"occlusion_discount_pixels": 2}),
    ("redert", ["--slant-cost", "1"], {"slant_cost": 1.0}),
]


@pytest.mark.parametrize(("method", "flags", "expected"), METHOD_FLAGS)
def test_method_options_reach_the_matcher(pair, monkeypatch, method, flags, expected):
    # each flag arrives as match()'s keyword, only when given, and the map written is the
    # one match() gives with that keyword
    import dcstereo

    folder, _ = pair
    seen = []
    real = dcstereo.match

    def spy(left, right, **kwargs):
        seen.append(kwargs)
        return real(left, right, **kwargs)

    monkeypatch.setattr(dcstereo, "match", spy)
    out = folder / "disp.pfm"
    args = [folder / "left.png", folder / "right.png", "--max-disparity", 10, "--method", method]
    result = invoke("run", *args, "-o", out, *flags, "-q")
    assert result.exit_code == 0, result.output
    assert len(seen) == 1
    given = {k: v for k, v in seen[0].items() if k in expected}
    assert given == expected
    # none of the other methods' parameters is passed: they keep the method's defaults
    from dcstereo.cli._common import METHOD_OPTIONS

    assert not set(seen[0]) & (set(METHOD_OPTIONS) - set(expected))
    left, right = io.read_image(folder / "left.png"), io.read_image(folder / "right.png")
    direct = real(left, right, max_disparity=10, method=method, **expected)
    disparity = io.read_disparity(out)
    np.testing.assert_array_equal(np.isfinite(disparity), np.isfinite(direct.disparity))
    np.testing.assert_array_equal(
        disparity[np.isfinite(disparity)], direct.disparity[np.isfinite(direct.disparity)]
    )


def test_method_options_change_the_features(pair):
    # a stricter SER keeps fewer of dc's pairs, each at least that SER; the left-right
    # check never adds one (a noisy right view: on the fixture's exact copy every SER is
    # infinite)
    folder, _ = pair
    right = io.read_image(folder / "right.png").astype(int)
    noise = np.random.default_rng(3).integers(-12, 13, right.shape)
    Image.fromarray(np.clip(right + noise, 0, 255).astype(np.uint8)).save(folder / "noisy.png")

    def features(name, *flags):
        csv = folder / f"{name}.csv"
        result = invoke(
            "run", folder / "left.png", folder / "noisy.png", "-o", folder / f"{name}.pfm",
            "--max-disparity", 10, "--features-out", csv, "--method", "dc", *flags, "-q",
        )  # fmt: skip
        assert result.exit_code == 0, result.output
        return io.read_features_csv(csv)

    default = features("default")
    strict = float(np.median(default[:, 3]))
    assert np.isfinite(strict)
    stricter = features("ser", "--ser-min", repr(strict))
    assert 0 < len(stricter) < len(default)
    assert (stricter[:, 3] >= strict).all()
    assert len(features("lr", "--lr-check")) <= len(default)


@pytest.mark.parametrize(
    ("method", "flags", "message"),
    [
        ("dsi3", ["--ser-min", "5"], "Error: --ser-min is read only by dc, dc-linear, not by dsi3"),
        ("block", ["--slant-cost", "1"], "Error: --slant-cost is read only by dsi5, dc, "),
        ("dc", ["--gcp-uniqueness", "2"], "Error: --gcp-uniqueness is read only by dsi3-gcp"),
        ("dc", ["--orientations", "0"], "Error: --orientations is read only by redert, not by dc"),
        ("dsi5", ["--no-lr-check"], "Error: --lr-check/--no-lr-check is read only by dc, "),
        ("dsi3", ["--vs-absolute"], "Error: --vs-relative/--vs-absolute is read only by dc, "),
        ("dc", ["--ser-min", "-1"], "Error: ser_min must be a non-negative number, got -1.0"),
        ("dc", ["--max-candidates", "-2"], "Error: max_candidates must be 0 (no limit) or"),
        ("redert", ["--orientations", "0,0.3"], "Error: orientations must be slopes from 0"),
        ("redert", ["--occlusion-discount", "1"], "Error: occlusion_discount must be a number"),
    ],
)
def test_method_options_refused_in_one_line_with_no_output(pair, method, flags, message):
    folder, _ = pair
    out = folder / "disp.pfm"
    args = [folder / "left.png", folder / "right.png", "--max-disparity", 10, "--method", method]
    result = CliRunner().invoke(main, [str(a) for a in ["run", *args, "-o", out, *flags]])
    assert result.exit_code == 1
    lines = result.output.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith(message), result.output
    assert not out.exists()


def test_orientations_that_are_not_numbers_are_a_usage_error(pair):
    folder, _ = pair
    args = [folder / "left.png", folder / "right.png", "--max-disparity", 10]
    result = CliRunner().invoke(
        main,
        [str(a) for a in ["run", *args, "-o", folder / "d.pfm", "--method", "redert"]]
        + ["--orientations", "0,x"],
    )
    assert result.exit_code == 2
    assert "Invalid value for '--orientations'" in result.output
    assert "got '0,x'" in result.output


def test_batch_and_video_take_the_method_options(pair, tmp_path):
    # the shared options reach batch (recorded in batch.json, so that a resume with other
    # values is refused) and video
    import json

    import dcstereo

    folder, _ = pair
    source = folder / "list.csv"
    source.write_text("left.png,right.png,one\n")
    out = tmp_path / "batch-out"
    base = ["batch", source, "-o", out, "--max-disparity", 10, "--method", "dc", "-q"]
    result = invoke(*base, "--ser-min", "7", "--lr-check")
    assert result.exit_code == 0, result.output
    recorded = json.loads((out / "batch.json").read_text())
    assert recorded["ser_min"] == 7.0 and recorded["lr_check"] is True
    refused = CliRunner().invoke(main, [str(a) for a in [*base, "--ser-min", "8"]])
    assert refused.exit_code == 1
    assert "ser_min 7.0 (now 8.0)" in refused.output
    result = CliRunner().invoke(
        main, [str(a) for a in [*base[:-3], "--method", "dsi3", "--ser-min", "8"]]
    )
    assert result.exit_code == 1
    assert "--ser-min is read only by dc, dc-linear, not by dsi3" in result.output
    # video: two folders of frames (one frame each here)
    frames = tmp_path / "left", tmp_path / "right"
    for side, name in zip(frames, ("left.png", "right.png"), strict=True):
        side.mkdir()
        (side / "f0.png").write_bytes((folder / name).read_bytes())
    out = tmp_path / "video-out"
    video = ["video", *frames, "-o", out, "--max-disparity", 10, "-q"]
    result = invoke(*video, "--method", "dc", "--vs-max", "0.05", "--edge-guard", "0")
    assert result.exit_code == 0, result.output
    left, right = io.read_image(folder / "left.png"), io.read_image(folder / "right.png")
    direct = dcstereo.match(left, right, max_disparity=10, method="dc", vs_max=0.05, edge_guard=0)
    written = io.read_disparity(next(out.glob("*.pfm")))
    np.testing.assert_array_equal(np.isfinite(written), np.isfinite(direct.disparity))
    np.testing.assert_array_equal(
        written[np.isfinite(written)], direct.disparity[np.isfinite(direct.disparity)]
    )
    video = [str(a) for a in [*video, "--method", "block", "--uniqueness", "1"]]
    refused = CliRunner().invoke(main, video)
    assert refused.exit_code == 1
    assert "--uniqueness is read only by dc, dc-linear, not by block" in refused.output


def test_the_docs_list_every_method_option_with_its_methods():
    # the command line page's table of the methods' options: one row per group of methods
    from pathlib import Path

    from dcstereo.cli._common import METHOD_OPTIONS, _flag

    page = Path(__file__).resolve().parents[1] / "docs" / "guide" / "cli.md"
    rows = {}
    for line in page.read_text(encoding="utf-8").splitlines():
        if line.startswith("| `") and "`--" in line:
            methods, flags = line.split("|")[1:3]
            for method in methods.replace("`", "").split(","):
                rows[method.strip()] = flags
    for name, methods in METHOD_OPTIONS.items():
        for method in methods:
            assert _flag(name).split("/")[0] in rows.get(method, ""), (name, method)


def test_help_tags_each_method_option_with_the_methods_that_read_it():
    from dcstereo.cli._common import METHOD_OPTIONS, _flag

    result = CliRunner().invoke(main, ["run", "--help"])
    assert result.exit_code == 0
    # each option's entry: from its flag to the next option (the help wraps)
    entries = {}
    for entry in result.output.split("\n  -")[1:]:
        entries["-" + entry.split()[0]] = " ".join(entry.split())
    for name, methods in METHOD_OPTIONS.items():
        entry = entries[_flag(name).split("/")[0]]
        assert f"[{', '.join(methods)}]" in entry, (name, entry)


def fresh_kernels():
    """Two new numba functions, one calling the other: compiled on their first call."""
    import numba

    inner = numba.njit(lambda x: x + 1)
    return numba.njit(lambda x: inner(x) * 2)


def compiling_first(real):
    """``real`` (a ``match``) after compiling new kernels: a kernel not yet compiled."""

    def compiling_match(*args, **kwargs):
        fresh_kernels()(1)
        return real(*args, **kwargs)

    return compiling_match


def test_compile_watch_announces_the_first_compile_and_times_it(capsys):
    import time

    from dcstereo.cli._common import COMPILE_NOTICE, compile_note, compile_watch

    outer = fresh_kernels()
    start = time.perf_counter()
    with compile_watch() as watch:
        assert outer(3) == 8
        assert fresh_kernels()(1) == 4  # a second compile: no second notice
    wall = time.perf_counter() - start
    assert capsys.readouterr().err == COMPILE_NOTICE + "\n"
    # the callee compiles inside its caller: counted once, so never more than the wall
    assert 0 < watch.seconds <= wall
    assert compile_note(watch) == f" ({watch.seconds:.1f} s of it compiling the kernels)"
    with compile_watch() as again:
        assert outer(4) == 10  # compiled already
    assert again.seconds == 0 and compile_note(again) == ""
    assert capsys.readouterr().err == ""
    with compile_watch(quiet=True) as quiet:
        assert fresh_kernels()(0) == 2
    assert quiet.seconds > 0 and capsys.readouterr().err == ""


def test_run_announces_compiling_and_says_its_share_of_the_time(pair, monkeypatch):
    import dcstereo
    from dcstereo.cli._common import COMPILE_NOTICE

    folder, _ = pair
    monkeypatch.setattr(dcstereo, "match", compiling_first(dcstereo.match))
    args = ["run", folder / "left.png", folder / "right.png", "-o", folder / "d.pfm"]
    result = CliRunner().invoke(main, [str(a) for a in [*args, "--max-disparity", 15]])
    assert result.exit_code == 0, result.output
    assert COMPILE_NOTICE in result.stderr
    assert "s of it compiling the kernels), " in result.stdout
    quiet = CliRunner().invoke(main, [str(a) for a in [*args, "--max-disparity", 15, "-q"]])
    assert quiet.exit_code == 0 and quiet.output == ""


def test_a_second_process_compiles_nothing(pair):
    # every kernel `run` calls is cached on disk: a later process loads them all, so no
    # compile notice and no compile time (a kernel without numba's cache would show here)
    import subprocess
    import sys

    folder, _ = pair
    command = [sys.executable, "-c", "from dcstereo.cli import main; main()", "run"]
    command += ["left.png", "right.png"]
    command += ["-o", "d.pfm", "--max-disparity", "15", "--preview", "p.png"]
    command += ["--confidence-out", "c.pfm"]
    for _ in range(2):
        done = subprocess.run(
            command, cwd=folder, capture_output=True, text=True, timeout=900, check=False
        )
        assert done.returncode == 0, done.stderr
    assert done.stderr == "" and "compiling" not in done.stdout, done.stdout + done.stderr


@pytest.mark.parametrize("command", ["batch", "video"])
def test_batch_and_video_announce_compiling_before_their_bar(command, pair, tmp_path, monkeypatch):
    import shutil

    import dcstereo.batch.folders
    import dcstereo.batch.video
    from dcstereo.cli._common import COMPILE_NOTICE

    module = dcstereo.batch.folders if command == "batch" else dcstereo.batch.video
    monkeypatch.setattr(module, "match", compiling_first(module.match))
    folder, _ = pair
    source, out = tmp_path / "source", tmp_path / "out"
    if command == "batch":
        (source / "pair0").mkdir(parents=True)
        for side in ("left", "right"):
            shutil.copy(folder / f"{side}.png", source / "pair0" / f"{side}.png")
        args = ["batch", source, "-o", out]
    else:
        for side in ("left", "right"):
            (source / side).mkdir(parents=True)
            for frame in range(2):
                shutil.copy(folder / f"{side}.png", source / side / f"img{frame}.png")
        args = ["video", source / "left", source / "right", "-o", out]
    result = CliRunner().invoke(main, [str(a) for a in [*args, "--max-disparity", 15]])
    assert result.exit_code == 0, result.output
    # once, and before the progress bar (which starts when the first pair is done)
    assert result.stderr.startswith(COMPILE_NOTICE + "\n")
    assert result.stderr.count(COMPILE_NOTICE) == 1


def test_the_cli_offers_every_method_option_of_the_library():
    # the flags' table and the library's readers are one list (the readers come from it)
    from dcstereo.cli import _common

    assert set(_common._METHOD_OPTION_TABLE) == set(params.METHOD_OPTIONS)
