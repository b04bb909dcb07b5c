"""Stereo sequences: frame folders, a video pair and a side-by-side video, in and out."""

from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from dcstereo import io, match
from dcstereo.batch import read_failures
from dcstereo.cli import main
from dcstereo.synthetic import synthetic_sequence
from dcstereo.video import open_sequence, read_video, write_video

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
    assert run_video(sources / "left", sources / "right", "-o", serial).exit_code == 0
    with (
        distributed.LocalCluster(
            n_workers=2, processes=True, threads_per_worker=1, dashboard_address=":0"
        ) as cluster,
        distributed.Client(cluster) as client,
    ):
        address = client.scheduler.address
        result = run_video(
            sources / "left", sources / "right", "-o", parallel, "--scheduler", address
        )
    assert result.exit_code == 0, result.output
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
    assert result.exit_code == 1 and "give the folder of right frames" in result.output
    result = run_video(sources / "left.mp4", sources / "right", "-o", tmp_path / "o")
    assert result.exit_code == 1 and "two of a kind" in result.output
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
