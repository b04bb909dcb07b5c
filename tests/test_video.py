"""Stereo sequences: frame folders, a video pair and a side-by-side video, in and out."""

import json
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from dcstereo import io, match
from dcstereo.batch.folders import read_failures
from dcstereo.batch.video import (
    depth_output_path,
    match_sequence,
    open_sequence,
    read_video,
    write_video,
)
from dcstereo.cli import main
from dcstereo.evaluation.synthetic import synthetic_sequence
from dcstereo.geometry import Calibration, depth

MAX_DISPARITY = 16
N_FRAMES = 5


@pytest.fixture(scope="module")
def frames():
    return synthetic_sequence(N_FRAMES, height=64, width=96, seed=21)


@pytest.fixture(scope="module")
def sources(tmp_path_factory, frames):
    root = tmp_path_factory.mktemp("sequence")
    for side in ("left", "right"):
        (root / side).mkdir()
        for i, frame in enumerate(frames):
            io.write_rgb_png(root / side / f"img{i:03d}.png", getattr(frame, side))
    write_video(root / "left.mp4", [f.left for f in frames], fps=5, quality=10)
    write_video(root / "right.mp4", [f.right for f in frames], fps=5, quality=10)
    sbs = [np.hstack([f.left, f.right]) for f in frames]
    write_video(root / "sbs.mp4", sbs, fps=5, quality=10)
    return root


def reference(frame):
    return match(frame.left, frame.right, max_disparity=MAX_DISPARITY).disparity


def run_video(*args):
    return CliRunner().invoke(main, ["video", *map(str, args), "--max-disparity", "16", "-q"])


def test_frame_folders_give_exactly_the_disparity_of_each_pair(sources, frames, tmp_path):
    out = tmp_path / "out"
    result = run_video(sources / "left", sources / "right", "-o", out)
    assert result.exit_code == 0, result.output
    for i, frame in enumerate(frames):
        written = io.read_pfm(out / f"frame{i:05d}.pfm")
        np.testing.assert_array_equal(written, np.where(np.isnan(d := reference(frame)), np.inf, d))
        assert io.read_image(out / f"frame{i:05d}-preview.png").shape[:2] == frame.left.shape
    assert read_failures(out) == []


def close_enough(written: np.ndarray, expected: np.ndarray) -> float:
    """Share of pixels whose disparity is within 1 px of the lossless result."""
    written = np.where(np.isinf(written), np.nan, written)
    both = np.isfinite(written) & np.isfinite(expected)
    return float(np.mean(np.abs(written - expected)[both] <= 1.0))


@pytest.mark.parametrize("inputs", [("left.mp4", "right.mp4"), ("sbs.mp4",)])
def test_videos_round_trip_to_close_disparities(sources, frames, tmp_path, inputs):
    sequence = open_sequence(*(sources / name for name in inputs))
    assert len(sequence) == N_FRAMES
    assert sequence.kind == ("videos" if len(inputs) == 2 else "side-by-side")
    decoded = list(sequence.frames())
    left, right = decoded[0].load()
    assert left.shape == right.shape == (64, 96, 3)
    out = tmp_path / "out"
    result = run_video(*(sources / n for n in inputs), "-o", out, "--format", "png")
    assert result.exit_code == 0, result.output
    for i, frame in enumerate(frames):
        written = io.read_disparity(out / f"frame{i:05d}.png")
        assert written.shape == frame.left.shape
        assert close_enough(written, reference(frame)) > 0.9


def test_preview_video_has_one_frame_per_frame(sources, tmp_path):
    movie = tmp_path / "preview.mp4"
    result = CliRunner().invoke(
        main,
        ["video", str(sources / "sbs.mp4"), "-o", str(tmp_path / "out")]
        + ["--max-disparity", "16", "--preview-video", str(movie), "--preview-style", "color"],
    )
    assert result.exit_code == 0, result.output
    assert f"{N_FRAMES} matched" in result.output
    shown = list(read_video(movie))
    assert len(shown) == N_FRAMES and shown[0].shape == (64, 96, 3)
    assert not [p for p in tmp_path.iterdir() if ".tmp" in p.name]


def test_rerun_resumes_and_no_resume_recomputes(sources, tmp_path):
    out = tmp_path / "out"
    args = ["video", str(sources / "left"), str(sources / "right"), "-o", str(out)]
    args += ["--max-disparity", "16"]
    assert CliRunner().invoke(main, args).exit_code == 0
    (out / "frame00002.pfm").unlink()
    mtime = (out / "frame00001.pfm").stat().st_mtime_ns
    again = CliRunner().invoke(main, args)
    assert again.exit_code == 0
    assert "1 matched, 4 already complete" in again.output
    assert (out / "frame00002.pfm").is_file()
    assert (out / "frame00001.pfm").stat().st_mtime_ns == mtime
    fresh = CliRunner().invoke(main, [*args, "--no-resume"])
    assert f"{N_FRAMES} matched, 0 already complete" in fresh.output


def test_a_corrupt_frame_is_reported_and_the_others_complete(sources, tmp_path):
    left, right = tmp_path / "left", tmp_path / "right"
    for side, folder in (("left", left), ("right", right)):
        folder.mkdir()
        for f in sorted((sources / side).iterdir()):
            (folder / f.name).write_bytes(f.read_bytes())
    (right / "img003.png").write_bytes(b"not a png")
    out = tmp_path / "out"
    result = run_video(left, right, "-o", out)
    assert result.exit_code == 1
    assert "1 of 5 frames failed" in result.output
    assert "Traceback" not in result.output
    failures = read_failures(out)
    assert [f["name"] for f in failures] == ["frame00003"]
    assert "img003.png" in failures[0]["error"]
    assert sorted(p.name for p in out.glob("frame*.pfm")) == [
        f"frame{i:05d}.pfm" for i in (0, 1, 2, 4)
    ]


def test_sequence_on_a_local_cluster_equals_serial(sources, tmp_path):
    distributed = pytest.importorskip("distributed")
    serial, parallel = tmp_path / "serial", tmp_path / "dask"
    (tmp_path / "calib.txt").write_text(RIG)
    extras = ("--calib", tmp_path / "calib.txt", "--ply")  # the clouds' colours travel too
    assert run_video(sources / "left", sources / "right", "-o", serial, *extras).exit_code == 0
    with (
        distributed.LocalCluster(
            n_workers=2, processes=True, threads_per_worker=1, dashboard_address=":0"
        ) as cluster,
        distributed.Client(cluster) as client,
    ):
        address = client.scheduler.address
        result = run_video(
            sources / "left", sources / "right", "-o", parallel, "--scheduler", address, *extras
        )
    assert result.exit_code == 0, result.output
    assert len(list(serial.glob("frame*.ply"))) == N_FRAMES
    for path in sorted(serial.glob("frame*")):
        assert (parallel / path.name).read_bytes() == path.read_bytes()


def test_bad_sequences_are_one_line_errors(sources, tmp_path):
    short = tmp_path / "short"
    short.mkdir()
    io.write_rgb_png(short / "a.png", np.zeros((64, 96), np.uint8))
    result = run_video(sources / "left", short, "-o", tmp_path / "o")
    assert result.exit_code == 1
    assert (
        result.output.strip() == f"Error: '{sources / 'left'}' holds 5 frames but '{short}' holds 1"
    )
    result = run_video(sources / "left", sources / "right.mp4", "-o", tmp_path / "o")
    assert result.exit_code == 1
    assert result.output.strip() == (
        f"Error: left '{sources / 'left'}' is a folder of frames, so right "
        f"'{sources / 'right.mp4'}' must be a folder too"
    )
    result = run_video(sources / "left", "-o", tmp_path / "o")
    assert result.exit_code == 1 and "give the folder of right frames" in result.output
    result = run_video(sources / "left.mp4", sources / "right", "-o", tmp_path / "o")
    assert result.exit_code == 1
    assert "right '" + str(sources / "right") + "' must be a video too" in result.output
    odd = tmp_path / "odd.mp4"
    write_video(odd, [np.zeros((16, 33), np.uint8)] * 2)
    assert open_sequence(odd).frame_count == 2  # padded to an even width: 34
    junk = tmp_path / "junk.mp4"
    junk.write_bytes(b"\x00" * 100)
    result = run_video(junk, "-o", tmp_path / "o")
    assert result.exit_code == 1 and "cannot read video" in result.output
    assert "Traceback" not in result.output


def test_frames_are_paired_in_name_order(sources):
    sequence = open_sequence(sources / "left", sources / "right")
    names = [Path(f.source.split(" | ")[0]).name for f in sequence.frames()]
    assert names == [f"img{i:03d}.png" for i in range(N_FRAMES)]


def test_match_sequence_creates_a_missing_output_folder_once_the_options_are_valid(
    sources, tmp_path
):
    sequence = open_sequence(sources / "left", sources / "right")
    with pytest.raises(ValueError, match="window"):
        match_sequence(sequence, tmp_path / "bad", max_disparity=MAX_DISPARITY, window=4)
    with pytest.raises(ValueError, match="preview_style"):
        match_sequence(sequence, tmp_path / "bad", max_disparity=MAX_DISPARITY, preview_style="x")
    assert not (tmp_path / "bad").exists()
    out = tmp_path / "new" / "frames"
    report = match_sequence(sequence, out, max_disparity=MAX_DISPARITY)
    assert report.ok and len(report.done) == N_FRAMES
    assert (out / "frame00004-preview.png").is_file()


def test_cli_option_errors_leave_no_output_folder(sources, tmp_path):
    for options in (["--window", "4"], ["--scheduler", "local:0"]):
        result = run_video(sources / "left", sources / "right", "-o", tmp_path / "o", *options)
        assert result.exit_code == 1
        assert len(result.output.strip().splitlines()) == 1, result.output
        assert not (tmp_path / "o").exists()


@pytest.mark.parametrize("disparity_format", ["pfm", "png"])
def test_damaged_frame_outputs_are_redone(sources, frames, tmp_path, disparity_format):
    out = tmp_path / "out"
    args = (sources / "left", sources / "right", "-o", out, "--format", disparity_format)
    assert run_video(*args).exit_code == 0
    damaged = out / f"frame00001.{disparity_format}"
    expected = damaged.read_bytes()
    damaged.write_bytes(expected[:100])
    preview = out / "frame00003-preview.png"
    preview.write_bytes(preview.read_bytes()[:-20])  # lost its end chunk
    result = CliRunner().invoke(
        main, ["video", *map(str, args), "--max-disparity", str(MAX_DISPARITY)]
    )
    assert result.exit_code == 0, result.output
    assert "2 matched, 3 already complete" in result.output
    assert damaged.read_bytes() == expected
    assert io.read_image(preview).shape[:2] == frames[3].left.shape


def test_resume_with_another_preview_style_or_format_is_refused(sources, tmp_path):
    out = tmp_path / "out"
    args = (sources / "left", sources / "right", "-o", out)
    assert run_video(*args).exit_code == 0
    result = run_video(*args, "--preview-style", "color", "--format", "png")
    assert result.exit_code == 1
    assert result.output.strip() == (
        f"Error: '{out}' holds outputs made with other options: disparity_format pfm (now png), "
        "preview_style paper (now color); use --no-resume (resume=False) to recompute, or "
        "another folder"
    )
    result = run_video(*args, "--preview-style", "color", "--no-resume")
    assert result.exit_code == 0 and (out / "batch.json").read_text().count('"color"') == 1
    assert run_video(*args, "--preview-style", "color").exit_code == 0
    assert run_video(*args).exit_code == 1
    # A batch.json from before these were recorded: made with the defaults.
    recorded = json.loads((out / "batch.json").read_text())
    del recorded["disparity_format"], recorded["preview_style"]
    (out / "batch.json").write_text(json.dumps(recorded))
    assert "preview_style paper (now color)" in run_video(*args, "--preview-style", "color").output
    result = CliRunner().invoke(main, ["video", *map(str, args), "--max-disparity", "16"])
    assert f"0 matched, {N_FRAMES} already complete" in result.output


def test_preview_video_may_go_into_the_output_folder_it_creates(sources, tmp_path):
    out = tmp_path / "new" / "out"
    movie = out / "preview.mp4"
    result = run_video(sources / "sbs.mp4", "-o", out, "--preview-video", movie)
    assert result.exit_code == 0, result.output
    assert len(list(read_video(movie))) == N_FRAMES
    result = run_video(sources / "sbs.mp4", "-o", out, "--preview-video", out / "x" / "p.mp4")
    assert result.exit_code == 1 and "does not exist" in result.output


# --------------------------------------------------------------------------- depth

RIG = "cam0=[200 0 47.5; 0 200 31.5; 0 0 1]\nbaseline=60\ndoffs=1\n"


def test_cli_video_depth_per_frame(sources, frames, tmp_path):
    (tmp_path / "calib.txt").write_text(RIG)
    calib = Calibration.from_middlebury(tmp_path / "calib.txt")
    out = tmp_path / "out"
    result = run_video(sources / "left", sources / "right", "-o", out, "--calib",
                       tmp_path / "calib.txt")  # fmt: skip
    assert result.exit_code == 0, result.output
    for i, frame in enumerate(frames):
        z = io.read_pfm(depth_output_path(out, i))
        assert z.shape == frame.left.shape[:2] and np.isfinite(z).mean() > 0.5
        np.testing.assert_array_equal(z, np.nan_to_num(depth(reference(frame), calib), nan=np.inf))
    assert json.loads((out / "batch.json").read_text())["depth"]["baseline"] == 60
    # a frame is complete only with its depth map; resuming without the calibration,
    # or with another, is refused
    depth_output_path(out, 3).unlink()
    again = run_video(sources / "left", sources / "right", "-o", out, "--calib",
                      tmp_path / "calib.txt")  # fmt: skip
    assert again.exit_code == 0 and depth_output_path(out, 3).is_file()
    report = match_sequence(open_sequence(sources / "left", sources / "right"), out,
                            max_disparity=MAX_DISPARITY, calibration=calib)  # fmt: skip
    assert report.done == [] and len(report.skipped) == N_FRAMES
    for other in (None, Calibration(200, 61, 47.5, 31.5, doffs=1)):
        with pytest.raises(ValueError, match="made with other options: depth"):
            match_sequence(open_sequence(sources / "left", sources / "right"), out,
                           max_disparity=MAX_DISPARITY, calibration=other)  # fmt: skip


def test_video_depth_errors(sources, tmp_path):
    with pytest.raises(TypeError, match="calibration must be a Calibration or None, got tuple"):
        match_sequence(open_sequence(sources / "left", sources / "right"), tmp_path / "o",
                       max_disparity=MAX_DISPARITY, calibration=(200, 60))  # fmt: skip
    result = run_video(sources / "left", sources / "right", "-o", tmp_path / "o", "--calib",
                       tmp_path / "missing.txt")  # fmt: skip
    lines = result.output.strip().splitlines()
    assert result.exit_code == 1 and len(lines) == 1 and "missing.txt" in lines[0], lines
    assert not (tmp_path / "o").exists()


def test_video_depth_as_16_bit_png(sources, frames, tmp_path):
    (tmp_path / "calib.txt").write_text(RIG)
    calib = Calibration.from_middlebury(tmp_path / "calib.txt")
    out = tmp_path / "out"
    options = ("--calib", tmp_path / "calib.txt", "--depth-format", "png", "--depth-scale", 2)
    result = run_video(sources / "left", sources / "right", "-o", out, *options)
    assert result.exit_code == 0, result.output
    for i, frame in enumerate(frames):
        io.write_depth(tmp_path / "expected.png", depth(reference(frame), calib), scale=2.0)
        written = depth_output_path(out, i, "png")
        assert written.name == f"frame{i:05d}-depth.png"
        assert written.read_bytes() == (tmp_path / "expected.png").read_bytes()
    assert not depth_output_path(out, 0).exists()
    result = run_video(sources / "left", sources / "right", "-o", tmp_path / "o",
                       "--depth-format", "png")  # fmt: skip
    lines = result.output.strip().splitlines()
    assert result.exit_code == 1
    assert lines == ["Error: --depth-format is used only with --calib (the depth maps)"]


def test_video_ply_per_frame(sources, frames, tmp_path):
    from dcstereo.batch.video import cloud_output_path
    from dcstereo.geometry import point_cloud

    (tmp_path / "calib.txt").write_text(RIG)
    calib = Calibration.from_middlebury(tmp_path / "calib.txt")
    out = tmp_path / "out"
    result = run_video(sources / "left", sources / "right", "-o", out, "--calib",
                       tmp_path / "calib.txt", "--ply")  # fmt: skip
    assert result.exit_code == 0, result.output
    for i, frame in enumerate(frames):
        cloud = point_cloud(reference(frame), calib, frame.left)
        io.write_ply(tmp_path / "expected.ply", cloud.points, cloud.colors)
        assert cloud_output_path(out, i).read_bytes() == (tmp_path / "expected.ply").read_bytes()
        assert cloud_output_path(out, i).name == f"frame{i:05d}.ply"
    # a cloud cut short redoes its frame; the cloud is a recorded option
    cut = cloud_output_path(out, 1)
    cut.write_bytes(cut.read_bytes()[:-3])
    report = match_sequence(open_sequence(sources / "left", sources / "right"), out,
                            max_disparity=MAX_DISPARITY, calibration=calib, ply=True)  # fmt: skip
    assert len(report.done) == 1 and len(report.skipped) == N_FRAMES - 1 and io.is_complete(cut)
    with pytest.raises(ValueError, match="other options: .*ply"):
        match_sequence(open_sequence(sources / "left", sources / "right"), out,
                       max_disparity=MAX_DISPARITY, calibration=calib)  # fmt: skip
    # a cloud needs the rig's geometry
    with pytest.raises(ValueError, match="ply=True needs a calibration"):
        match_sequence(open_sequence(sources / "left", sources / "right"), tmp_path / "o",
                       max_disparity=MAX_DISPARITY, ply=True)  # fmt: skip
    result = run_video(sources / "left", sources / "right", "-o", tmp_path / "o", "--ply")
    lines = result.output.strip().splitlines()
    assert result.exit_code == 1
    assert lines == ["Error: --ply needs --calib (the point clouds' geometry)"]
    assert not (tmp_path / "o").exists()


def test_video_confidence_per_frame(sources, frames, tmp_path):
    from dcstereo.batch.video import confidence_output_path
    from dcstereo.refine.confidence import confidence

    out = tmp_path / "out"
    result = run_video(sources / "left", sources / "right", "-o", out, "--confidence")
    assert result.exit_code == 0, result.output
    for i, frame in enumerate(frames):
        plain = match(frame.left, frame.right, max_disparity=MAX_DISPARITY)
        expected = confidence(plain, frame.left, frame.right)
        np.testing.assert_array_equal(
            io.read_pfm(confidence_output_path(out, i)), np.nan_to_num(expected, nan=np.inf)
        )
    confidence_output_path(out, 2).unlink()
    report = match_sequence(open_sequence(sources / "left", sources / "right"), out,
                            max_disparity=MAX_DISPARITY, confidence=True)  # fmt: skip
    assert len(report.done) == 1 and len(report.skipped) == N_FRAMES - 1
    assert confidence_output_path(out, 2).is_file()
    with pytest.raises(ValueError, match="other options: confidence"):
        match_sequence(open_sequence(sources / "left", sources / "right"), out,
                       max_disparity=MAX_DISPARITY)  # fmt: skip
