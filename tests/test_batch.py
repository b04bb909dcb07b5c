"""Batches of pairs: serial and on a Dask LocalCluster, resume, failures, lost workers."""

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from dcstereo import io, match
from dcstereo.batch.folders import (
    FAILURES_FILE,
    Pair,
    cloud_path,
    depth_path,
    find_pairs,
    output_path,
    read_failures,
    run_batch,
)
from dcstereo.cli import main
from dcstereo.evaluation.synthetic import synthetic_sequence
from dcstereo.geometry import Calibration, depth, point_cloud

distributed = pytest.importorskip("distributed")

MAX_DISPARITY = 16


def _local_cluster():
    return distributed.LocalCluster(
        n_workers=2, processes=True, threads_per_worker=1, dashboard_address=":0"
    )


@pytest.fixture(scope="module")
def dask_client():
    with _local_cluster() as cluster, distributed.Client(cluster) as client:
        yield client


def write_pairs(root: Path, frames, *, middlebury=False) -> Path:
    names = ("im0.png", "im1.png") if middlebury else ("left.png", "right.png")
    for i, frame in enumerate(frames):
        folder = root / f"pair{i:02d}"
        folder.mkdir(parents=True)
        io.write_rgb_png(folder / names[0], frame.left)
        io.write_rgb_png(folder / names[1], frame.right)
    return root


@pytest.fixture(scope="module")
def pairs_dir(tmp_path_factory):
    return write_pairs(tmp_path_factory.mktemp("pairs"), synthetic_sequence(6, seed=11))


@pytest.fixture(scope="module")
def slow_pairs_dir(tmp_path_factory):
    """Pairs that take a few hundred milliseconds each on one thread (room to kill)."""
    frames = synthetic_sequence(
        8, height=360, width=600, background_disparity=(4, 12), foreground_disparity=40, seed=3
    )
    return write_pairs(tmp_path_factory.mktemp("slow"), frames)


def outputs(folder: Path) -> list[Path]:
    return [p for p in folder.glob("*.pfm") if not p.name.startswith(".")]


def expected_pfm(pair: Pair, tmp: Path, **kwargs) -> bytes:
    result = match(io.read_image(pair.left), io.read_image(pair.right), **kwargs)
    path = tmp / f"expected-{pair.name}.pfm"
    io.write_disparity(path, result.disparity)
    return path.read_bytes()


def test_find_pairs_in_a_folder_of_pair_folders(tmp_path):
    frames = synthetic_sequence(2, height=32, width=48, seed=0)
    write_pairs(tmp_path / "a", frames)
    write_pairs(tmp_path / "b", frames, middlebury=True)
    pairs = find_pairs(tmp_path / "a")
    assert [p.name for p in pairs] == ["pair00", "pair01"]
    assert pairs[0].left.name == "left.png" and pairs[0].right.name == "right.png"
    pairs = find_pairs(tmp_path / "b")
    assert pairs[1].left.name == "im0.png" and pairs[1].right.name == "im1.png"
    (tmp_path / "b" / "pair01" / "im1.png").unlink()
    (tmp_path / "b" / "zz-empty").mkdir()
    pairs = find_pairs(tmp_path / "b")
    assert pairs[0].problem is None
    assert "im1" in pairs[1].problem
    assert "neither" in pairs[2].problem
    with pytest.raises(ValueError, match="no pair folders"):
        find_pairs(tmp_path / "b" / "zz-empty")


def test_find_pairs_in_a_csv(tmp_path):
    frames = synthetic_sequence(2, height=32, width=48, seed=0)
    write_pairs(tmp_path, frames)
    (tmp_path / "list.csv").write_text(
        "left,right,name\npair00/left.png,pair00/right.png,first\npair01/left.png,pair01/right.png\n"
    )
    pairs = find_pairs(tmp_path / "list.csv")
    assert [p.name for p in pairs] == ["first", "pair01"]
    assert pairs[0].left == tmp_path / "pair00" / "left.png"
    (tmp_path / "bad.csv").write_text("a.png\n")
    with pytest.raises(ValueError, match="pair 1"):
        find_pairs(tmp_path / "bad.csv")
    (tmp_path / "twice.csv").write_text("a.png,b.png,x\nc.png,d.png,x\n")
    with pytest.raises(ValueError, match="used twice"):
        find_pairs(tmp_path / "twice.csv")


def test_serial_batch_writes_what_match_gives(pairs_dir, tmp_path):
    out = tmp_path / "out"
    out.mkdir()
    pairs = find_pairs(pairs_dir)
    seen = []
    report = run_batch(pairs, out, max_disparity=MAX_DISPARITY, on_outcome=seen.append)
    assert report.ok and report.done == [p.name for p in pairs]
    assert sorted(o.pair.name for o in seen) == sorted(report.done)
    for pair in pairs:
        expected = expected_pfm(pair, tmp_path, max_disparity=MAX_DISPARITY)
        assert output_path(out, pair).read_bytes() == expected
    assert read_failures(out) == []


def test_local_cluster_gives_byte_identical_outputs(pairs_dir, tmp_path, dask_client):
    pairs = find_pairs(pairs_dir)
    serial, parallel = tmp_path / "serial", tmp_path / "dask"
    serial.mkdir()
    parallel.mkdir()
    options = {"max_disparity": MAX_DISPARITY, "method": "dsi5", "window": 7}
    assert run_batch(pairs, serial, **options).ok
    report = run_batch(pairs, parallel, client=dask_client, **options)
    assert report.ok and sorted(report.done) == [p.name for p in pairs]
    for pair in pairs:
        assert output_path(parallel, pair).read_bytes() == output_path(serial, pair).read_bytes()


def test_cli_batch_on_a_scheduler_address(pairs_dir, tmp_path, dask_client):
    out = tmp_path / "out"
    address = dask_client.scheduler.address
    args = ["batch", str(pairs_dir), "-o", str(out), "--max-disparity", str(MAX_DISPARITY)]
    result = CliRunner().invoke(main, [*args, "--scheduler", address, "-q"])
    assert result.exit_code == 0, result.output
    for pair in find_pairs(pairs_dir):
        expected = expected_pfm(pair, tmp_path, max_disparity=MAX_DISPARITY)
        assert output_path(out, pair).read_bytes() == expected


def test_a_corrupt_pair_is_reported_and_the_others_complete(pairs_dir, tmp_path):
    broken = tmp_path / "pairs"
    for src in sorted(pairs_dir.iterdir()):
        (broken / src.name).mkdir(parents=True)
        for f in src.iterdir():
            (broken / src.name / f.name).write_bytes(f.read_bytes())
    right = broken / "pair02" / "right.png"
    right.write_bytes(right.read_bytes()[:200])  # truncated PNG
    small = synthetic_sequence(1, height=40, width=64, seed=0)[0]
    io.write_rgb_png(broken / "pair04" / "right.png", small.right)  # wrong size
    out = tmp_path / "out"
    args = ["batch", str(broken), "-o", str(out), "--max-disparity", str(MAX_DISPARITY)]
    result = CliRunner().invoke(main, args)
    assert result.exit_code == 1
    assert "2 of 6 pairs failed" in result.output
    assert "Traceback" not in result.output
    failures = read_failures(out)
    assert [f["name"] for f in failures] == ["pair02", "pair04"]
    assert "pair02/right.png" in failures[0]["error"]
    assert "differ in shape" in failures[1]["error"]
    done = sorted(p.stem for p in out.glob("*.pfm"))
    assert done == ["pair00", "pair01", "pair03", "pair05"]
    # The rerun skips the complete pairs and fails the same two again.
    again = CliRunner().invoke(main, args)
    assert again.exit_code == 1
    assert "4 already complete, 2 failed" in again.output
    right.write_bytes((pairs_dir / "pair02" / "right.png").read_bytes())
    io.write_rgb_png(
        broken / "pair04" / "right.png", io.read_image(pairs_dir / "pair04" / "right.png")
    )
    fixed = CliRunner().invoke(main, args)
    assert fixed.exit_code == 0, fixed.output
    assert "2 matched, 4 already complete, 0 failed" in fixed.output
    assert read_failures(out) == []


def test_resume_after_the_process_is_killed(slow_pairs_dir, tmp_path):
    out = tmp_path / "out"
    command = [
        sys.executable,
        "-c",
        "from dcstereo.cli import main; main()",
        "batch",
        str(slow_pairs_dir),
        "-o",
        str(out),
        "--max-disparity",
        "48",
        "--method",
        "dsi5",
        "--threads",
        "1",
        "-q",
    ]
    process = subprocess.Popen(command, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    try:
        deadline = time.monotonic() + 120
        while not outputs(out) and process.poll() is None:
            assert time.monotonic() < deadline, "the batch wrote nothing in 120 s"
            time.sleep(0.002)
        os.kill(process.pid, signal.SIGKILL)
    finally:
        process.wait()
        process.stderr.close()
    assert process.returncode == -signal.SIGKILL
    before = {p.name: p.stat().st_mtime_ns for p in outputs(out)}
    pairs = find_pairs(slow_pairs_dir)
    assert 0 < len(before) < len(pairs)
    report = run_batch(pairs, out, max_disparity=48, method="dsi5")
    assert report.ok
    assert sorted(report.skipped) == sorted(Path(n).stem for n in before)
    assert sorted(report.done) == sorted(p.name for p in pairs if f"{p.name}.pfm" not in before)
    for name, mtime in before.items():
        assert (out / name).stat().st_mtime_ns == mtime  # not recomputed
    for pair in pairs:
        expected = expected_pfm(pair, tmp_path, max_disparity=48, method="dsi5")
        assert output_path(out, pair).read_bytes() == expected
    assert not [p for p in out.iterdir() if ".tmp" in p.name]


def test_no_resume_recomputes_and_other_options_are_refused(pairs_dir, tmp_path):
    out = tmp_path / "out"
    out.mkdir()
    pairs = find_pairs(pairs_dir)[:2]
    assert run_batch(pairs, out, max_disparity=MAX_DISPARITY).done == ["pair00", "pair01"]
    assert run_batch(pairs, out, max_disparity=MAX_DISPARITY).skipped == ["pair00", "pair01"]
    again = run_batch(pairs, out, max_disparity=MAX_DISPARITY, resume=False)
    assert again.done == ["pair00", "pair01"]
    with pytest.raises(ValueError, match="other options"):
        run_batch(pairs, out, max_disparity=MAX_DISPARITY, method="block")
    assert run_batch(pairs, out, max_disparity=MAX_DISPARITY, method="block", resume=False).ok


def test_a_worker_killed_mid_batch_costs_only_its_tasks(slow_pairs_dir, tmp_path):
    pairs = find_pairs(slow_pairs_dir)
    killed = []

    with _local_cluster() as cluster, distributed.Client(cluster) as client:

        def kill_a_busy_worker(outcome):
            if killed:
                return
            busy = [w for w, keys in client.processing().items() if keys]
            if not busy:
                return
            pid = client.run(os.getpid, workers=busy[:1])[busy[0]]
            os.kill(pid, signal.SIGKILL)
            killed.append(pid)

        report = run_batch(
            pairs,
            tmp_path,
            client=client,
            max_disparity=48,
            method="dsi5",
            on_outcome=kill_a_busy_worker,
        )
    assert killed
    assert report.ok, report.failed
    assert sorted(report.done) == [p.name for p in pairs]
    for pair in pairs:
        expected = expected_pfm(pair, tmp_path, max_disparity=48, method="dsi5")
        assert output_path(tmp_path, pair).read_bytes() == expected


def test_cli_scheduler_errors_are_one_line(pairs_dir, tmp_path):
    args = ["batch", str(pairs_dir), "-o", str(tmp_path / "o"), "--max-disparity", "8"]
    result = CliRunner().invoke(main, [*args, "--scheduler", "local:0"])
    assert result.exit_code == 1
    assert result.output.strip().splitlines() == [
        "Error: --scheduler local:N needs N >= 1 workers, got 'local:0'"
    ]
    result = CliRunner().invoke(main, [*args, "--window", "4"])
    assert result.exit_code == 1 and "window" in result.output
    assert "Traceback" not in result.output


def test_failures_file_is_written_even_when_nothing_fails(pairs_dir, tmp_path):
    report = run_batch(find_pairs(pairs_dir)[:1], tmp_path, max_disparity=MAX_DISPARITY)
    assert report.ok
    assert (tmp_path / FAILURES_FILE).read_text().strip() == "name,left,right,error"
    assert np.isfinite(io.read_pfm(tmp_path / "pair00.pfm")).mean() > 0.8


def test_run_batch_creates_a_missing_output_folder_once_the_options_are_valid(pairs_dir, tmp_path):
    pairs = find_pairs(pairs_dir)[:1]
    with pytest.raises(ValueError, match="window"):
        run_batch(pairs, tmp_path / "bad", max_disparity=MAX_DISPARITY, window=4)
    assert not (tmp_path / "bad").exists()
    out = tmp_path / "new" / "out"
    assert run_batch(pairs, out, max_disparity=MAX_DISPARITY).done == ["pair00"]
    assert output_path(out, pairs[0]).is_file()
    (tmp_path / "file").write_text("")
    with pytest.raises(ValueError, match=f"'{tmp_path / 'file'}': it is not a folder"):
        run_batch(pairs, tmp_path / "file", max_disparity=MAX_DISPARITY)


@pytest.mark.parametrize(
    "options",
    [
        ["--window", "4"],
        ["--min-disparity", "9"],
        ["--occlusion-cost", "-1"],
        ["--scheduler", "bogus"],
        ["--scheduler", "local:0"],
    ],
)
def test_cli_option_errors_leave_no_output_folder(pairs_dir, tmp_path, options):
    out = tmp_path / "a" / "out"
    args = ["batch", str(pairs_dir), "-o", str(out), "--max-disparity", "8", *options]
    result = CliRunner().invoke(main, args)
    assert result.exit_code == 1
    assert len(result.output.strip().splitlines()) == 1, result.output
    assert not (tmp_path / "a").exists()


def test_a_damaged_output_is_redone_not_counted_complete(pairs_dir, tmp_path):
    out = tmp_path / "out"
    pairs = find_pairs(pairs_dir)[:3]
    assert run_batch(pairs, out, max_disparity=MAX_DISPARITY).ok
    cut = output_path(out, pairs[0])
    cut.write_bytes(cut.read_bytes()[:100])
    output_path(out, pairs[2]).write_bytes(b"Pf\n")  # header cut short
    report = run_batch(pairs, out, max_disparity=MAX_DISPARITY)
    assert report.done == ["pair00", "pair02"] and report.skipped == ["pair01"]
    for pair in pairs:
        expected = expected_pfm(pair, tmp_path, max_disparity=MAX_DISPARITY)
        assert output_path(out, pair).read_bytes() == expected
    cut.write_bytes(cut.read_bytes()[:100])
    args = ["batch", str(pairs_dir), "-o", str(out), "--max-disparity", str(MAX_DISPARITY)]
    result = CliRunner().invoke(main, args)
    assert result.exit_code == 0, result.output
    assert "4 matched, 2 already complete" in result.output


def test_resume_refusal_names_only_the_options_that_differ(pairs_dir, tmp_path):
    pairs = find_pairs(pairs_dir)[:1]
    assert run_batch(pairs, tmp_path, max_disparity=MAX_DISPARITY, method="dc").ok
    with pytest.raises(ValueError) as refused:
        run_batch(pairs, tmp_path, max_disparity=12, method="block")
    assert str(refused.value) == (
        f"'{tmp_path}' holds outputs made with other options: max_disparity 16 (now 12), "
        "method dc (now block); use --no-resume (resume=False) to recompute, or another folder"
    )


@pytest.mark.parametrize("content", [b"{not json", b"[1, 2]", b"\xff\xfe"])
def test_an_unreadable_batch_json_is_named_not_shown_as_none(pairs_dir, tmp_path, content):
    pairs = find_pairs(pairs_dir)[:1]
    assert run_batch(pairs, tmp_path, max_disparity=MAX_DISPARITY).ok
    (tmp_path / "batch.json").write_bytes(content)
    with pytest.raises(ValueError, match=r"^cannot read .*batch\.json: .*; remove it or use --no-"):
        run_batch(pairs, tmp_path, max_disparity=MAX_DISPARITY)
    args = [
        "batch",
        str(pairs_dir),
        "-o",
        str(tmp_path),
        "--max-disparity",
        str(MAX_DISPARITY),
        "-q",
    ]
    result = CliRunner().invoke(main, args)
    assert result.exit_code == 1
    lines = result.output.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith(f"Error: cannot read {tmp_path / 'batch.json'}")
    assert run_batch(pairs, tmp_path, max_disparity=MAX_DISPARITY, resume=False).ok
    assert run_batch(pairs, tmp_path, max_disparity=MAX_DISPARITY).skipped == ["pair00"]


def test_cli_refused_resume_prints_one_line_and_no_bar(pairs_dir, tmp_path):
    args = ["batch", str(pairs_dir), "-o", str(tmp_path / "o"), "--window", "3"]
    first = CliRunner().invoke(main, [*args, "--max-disparity", "8"])
    assert first.exit_code == 0, first.output
    assert "batch" in first.output and "━" in first.output  # the bar, when anything runs
    result = CliRunner().invoke(main, [*args, "--max-disparity", "9"])
    assert result.exit_code == 1
    assert result.output.strip("\n").splitlines() == [
        f"Error: '{tmp_path / 'o'}' holds outputs made with other options: max_disparity 8 "
        "(now 9); use --no-resume (resume=False) to recompute, or another folder"
    ]


# --------------------------------------------------------------------------- depth

CALIB_A = "cam0=[300 0 23.5; 0 300 15.5; 0 0 1]\nbaseline=80\n"
CALIB_B = "cam0=[500 0 20; 0 500 16; 0 0 1]\nbaseline=120\ndoffs=2\n"


@pytest.fixture
def calib_pairs(tmp_path):
    """Three Middlebury-style pair folders: two with their own calib.txt, one without."""
    root = write_pairs(tmp_path / "pairs", synthetic_sequence(3, height=32, width=48, seed=5),
                       middlebury=True)  # fmt: skip
    (root / "pair00" / "calib.txt").write_text(CALIB_A)
    (root / "pair01" / "calib.txt").write_text(CALIB_B)
    return root


def pair_disparity(pair: Pair, **kwargs) -> np.ndarray:
    """What ``match`` gives for the pair: the disparity every expected output is made from."""
    return match(io.read_image(pair.left), io.read_image(pair.right), **kwargs).disparity


def expected_depth(pair: Pair, calibration: Calibration, **kwargs) -> np.ndarray:
    # what the PFM holds: float32, inf where there is no depth
    return np.nan_to_num(depth(pair_disparity(pair, **kwargs), calibration), nan=np.inf)


def batch_with_one_calibration(calib_pairs, tmp_path, out, *options):
    """``batch`` from the command line with CALIB_B for every pair; ``(result, calib)``."""
    (tmp_path / "all.txt").write_text(CALIB_B)
    args = ["batch", str(calib_pairs), "-o", str(out), "--max-disparity", "8", "-q", "--calib",
            str(tmp_path / "all.txt"), *options]  # fmt: skip
    return CliRunner().invoke(main, args), Calibration.from_middlebury(tmp_path / "all.txt")


def test_batch_depth_from_each_pair_folders_calib(calib_pairs, tmp_path):
    pairs = find_pairs(calib_pairs)
    assert [p.calib for p in pairs] == [
        calib_pairs / "pair00" / "calib.txt", calib_pairs / "pair01" / "calib.txt", None
    ]  # fmt: skip
    out = tmp_path / "out"
    report = run_batch(pairs, out, max_disparity=8, depth=True)
    assert report.done == ["pair00", "pair01"]
    (failed,) = report.failed
    assert failed.pair.name == "pair02" and failed.message == (
        "pair 'pair02' has no calib.txt for its depth (give one calibration for all pairs: "
        "calibration=, or batch --calib)"
    )
    for pair, baseline in zip(pairs[:2], (80, 120), strict=True):
        calib = Calibration.from_middlebury(pair.calib)
        assert calib.baseline == baseline  # each pair's own file
        z = io.read_pfm(depth_path(out, pair))
        np.testing.assert_array_equal(z, expected_depth(pair, calib, max_disparity=8))
        assert np.isfinite(z).mean() > 0.5
    assert not depth_path(out, pairs[2]).exists() and not output_path(out, pairs[2]).exists()
    # resume: complete only when both files are; a missing depth map redoes its pair
    depth_path(out, pairs[0]).unlink()
    again = run_batch(pairs, out, max_disparity=8, depth=True)
    assert again.done == ["pair00"] and again.skipped == ["pair01"]
    assert depth_path(out, pairs[0]).is_file()
    # a calib.txt that cannot be read fails its pair only, before matching
    (calib_pairs / "pair01" / "calib.txt").write_text("baseline=80\n")
    bad = run_batch(pairs, tmp_path / "bad", max_disparity=8, depth=True)
    assert bad.done == ["pair00"]
    assert [o.pair.name for o in bad.failed] == ["pair01", "pair02"]
    assert "cam0" in bad.failed[0].message
    assert not output_path(tmp_path / "bad", pairs[1]).exists()


def test_batch_depth_with_one_calibration_for_all(calib_pairs, tmp_path):
    pairs = find_pairs(calib_pairs)
    calib = Calibration(focal=400, baseline=50, cx=20, cy=12)
    out = tmp_path / "out"
    report = run_batch(pairs, out, max_disparity=8, depth=True, calibration=calib)
    assert report.ok and report.done == ["pair00", "pair01", "pair02"]
    for pair in pairs:  # the pair folders' own calib.txt are not used
        np.testing.assert_array_equal(
            io.read_pfm(depth_path(out, pair)), expected_depth(pair, calib, max_disparity=8)
        )
    # the calibration is one of the recorded options: resuming with another is refused
    with pytest.raises(ValueError, match="holds outputs made with other options: depth"):
        run_batch(pairs, out, max_disparity=8, depth=True)
    # and resuming without depth over them is too (they were made with it)
    with pytest.raises(ValueError, match="other options: depth"):
        run_batch(pairs, out, max_disparity=8)


def test_batch_depth_on_dask_equals_serial(calib_pairs, tmp_path, dask_client):
    pairs = find_pairs(calib_pairs)
    serial = run_batch(pairs, tmp_path / "serial", max_disparity=8, depth=True)
    parallel = run_batch(pairs, tmp_path / "dask", max_disparity=8, depth=True,
                         client=dask_client)  # fmt: skip
    assert serial.done == parallel.done == ["pair00", "pair01"]
    for pair in pairs[:2]:
        for where in (output_path, depth_path):
            a, b = where(tmp_path / "serial", pair), where(tmp_path / "dask", pair)
            assert a.read_bytes() == b.read_bytes()


@pytest.mark.parametrize(
    "options, error, message",
    [
        ({"calibration": Calibration(1, 1, 0, 0)}, ValueError,
         "calibration is used only with depth=True"),
        ({"depth": True, "calibration": {"focal": 1}}, TypeError,
         "calibration must be a Calibration or None, got dict"),
        ({"depth": "yes"}, TypeError, "depth must be a bool, got 'yes'"),
    ],
)  # fmt: skip
def test_batch_depth_options_are_checked_first(calib_pairs, tmp_path, options, error, message):
    with pytest.raises(error, match=message):
        run_batch(find_pairs(calib_pairs), tmp_path / "out", max_disparity=8, **options)
    assert not (tmp_path / "out").exists()


def test_cli_batch_depth(calib_pairs, tmp_path):
    out = tmp_path / "out"
    args = ["batch", str(calib_pairs), "-o", str(out), "--max-disparity", "8", "-q"]
    result, calib = batch_with_one_calibration(calib_pairs, tmp_path, out, "--depth")
    assert result.exit_code == 0, result.output
    for pair in find_pairs(calib_pairs):
        np.testing.assert_array_equal(
            io.read_pfm(out / "depth" / f"{pair.name}.pfm"),
            expected_depth(pair, calib, max_disparity=8),
        )
    # each pair folder's own: pair02 has none and fails, the others are written
    result = CliRunner().invoke(main, [*args[:3], str(tmp_path / "own"), *args[4:], "--depth"])
    assert result.exit_code == 1
    assert "failed: pair02: pair 'pair02' has no calib.txt for its depth" in result.output
    assert sorted(p.name for p in (tmp_path / "own" / "depth").iterdir()) == [
        "pair00.pfm", "pair01.pfm"
    ]  # fmt: skip
    # --calib without --depth, and a calib file that cannot be read: one line, no folder
    for extra, message in (
        (["--calib", str(tmp_path / "all.txt")], "--calib is used only with --depth"),
        (["--depth", "--calib", str(tmp_path / "none.txt")], "none.txt: file does not exist"),
    ):
        result = CliRunner().invoke(main, [*args[:3], str(tmp_path / "x"), *args[4:], *extra])
        lines = result.output.strip().splitlines()
        assert result.exit_code == 1 and len(lines) == 1 and message in lines[0], lines
        assert not (tmp_path / "x").exists()


def expected_depth_png(pair, calibration, folder, scale, **kwargs) -> bytes:
    """The bytes of the 16-bit depth PNG ``run --depth-out z.png`` would write."""
    z = depth(pair_disparity(pair, **kwargs), calibration)
    io.write_depth(folder / "expected.png", z, scale=scale)
    return (folder / "expected.png").read_bytes()


def test_batch_depth_as_16_bit_png(calib_pairs, tmp_path):
    import json

    pairs = find_pairs(calib_pairs)[:2]
    out = tmp_path / "out"
    report = run_batch(pairs, out, max_disparity=8, depth=True, depth_format="png",
                       depth_scale=4.0)  # fmt: skip
    assert report.done == ["pair00", "pair01"]
    for pair in pairs:
        calib = Calibration.from_middlebury(pair.calib)
        written = depth_path(out, pair, "png")
        assert written.name == f"{pair.name}.png" and not depth_path(out, pair).exists()
        assert written.read_bytes() == expected_depth_png(pair, calib, tmp_path, 4.0,
                                                          max_disparity=8)  # fmt: skip
    assert json.loads((out / "batch.json").read_text())["depth_png_scale"] == 4.0
    # resuming: the same skips; another format or scale is refused
    assert run_batch(pairs, out, max_disparity=8, depth=True, depth_format="png",
                     depth_scale=4.0).skipped == ["pair00", "pair01"]  # fmt: skip
    for other in ({}, {"depth_format": "png"}):
        with pytest.raises(ValueError, match="other options: depth_png_scale"):
            run_batch(pairs, out, max_disparity=8, depth=True, **other)
    # a PNG cut short redoes its pair
    cut = depth_path(out, pairs[1], "png")
    cut.write_bytes(cut.read_bytes()[:-20])
    again = run_batch(pairs, out, max_disparity=8, depth=True, depth_format="png",
                      depth_scale=4.0)  # fmt: skip
    assert again.done == ["pair01"] and io.is_complete(cut)


@pytest.mark.parametrize(
    "options, message",
    [
        ({"depth": True, "depth_format": "tif"}, "depth_format must be 'pfm' or 'png', got 'tif'"),
        ({"depth_format": "png"}, "depth_format is used only when the depth maps are written"),
        ({"depth": True, "depth_scale": 2.0}, "depth_scale is used only with depth_format='png'"),
        ({"depth": True, "depth_format": "png", "depth_scale": 0},
         "depth_scale must be a positive number, got 0"),
    ],
)  # fmt: skip
def test_batch_depth_format_options_are_checked_first(calib_pairs, tmp_path, options, message):
    with pytest.raises(ValueError, match=message):
        run_batch(find_pairs(calib_pairs), tmp_path / "out", max_disparity=8, **options)
    assert not (tmp_path / "out").exists()


def test_cli_batch_depth_png(calib_pairs, tmp_path):
    out = tmp_path / "out"
    result, calib = batch_with_one_calibration(
        calib_pairs, tmp_path, out, "--depth", "--depth-format", "png", "--depth-scale", "10"
    )
    assert result.exit_code == 0, result.output
    args = ["batch", str(calib_pairs), "--max-disparity", "8", "-q", "--calib",
            str(tmp_path / "all.txt")]  # fmt: skip
    for pair in find_pairs(calib_pairs):
        assert (out / "depth" / f"{pair.name}.png").read_bytes() == expected_depth_png(
            pair, calib, tmp_path, 10.0, max_disparity=8
        )
    for extra, message in (
        (["--depth-format", "png"], "--depth-format is used only with --depth"),
        (["--depth", "--depth-scale", "3"], "--depth-scale is used only with --depth-format png"),
        (["--depth", "--depth-format", "png", "--depth-scale", "-1"],
         "depth_scale must be a positive number, got -1"),
    ):  # fmt: skip
        result = CliRunner().invoke(main, [*args[:4], "-o", str(tmp_path / "x"), *extra])
        lines = result.output.strip().splitlines()
        assert result.exit_code == 1 and len(lines) == 1 and message in lines[0], lines
        assert not (tmp_path / "x").exists()


def expected_cloud(pair: Pair, calibration: Calibration, folder: Path, **kwargs) -> bytes:
    """The bytes of the PLY file ``run`` would write for the pair."""
    cloud = point_cloud(pair_disparity(pair, **kwargs), calibration, io.read_image(pair.left))
    io.write_ply(folder / f"{pair.name}-expected.ply", cloud.points, cloud.colors)
    return (folder / f"{pair.name}-expected.ply").read_bytes()


def test_batch_ply_from_each_pair_folders_calib(calib_pairs, tmp_path):
    pairs = find_pairs(calib_pairs)
    out = tmp_path / "out"
    report = run_batch(pairs, out, max_disparity=8, ply=True, fill=True)
    assert report.done == ["pair00", "pair01"]
    assert report.failed[0].message.startswith(
        "pair 'pair02' has no calib.txt for its point cloud (give one calibration"
    )
    for pair in pairs[:2]:
        calib = Calibration.from_middlebury(pair.calib)
        expected = expected_cloud(pair, calib, tmp_path, max_disparity=8, fill=True)
        assert cloud_path(out, pair).read_bytes() == expected
        assert io.is_complete(cloud_path(out, pair))
        assert not depth_path(out, pair).exists()  # only what was asked for
    # resume: a cloud cut short is not complete, and its pair is redone
    cut = cloud_path(out, pairs[0])
    cut.write_bytes(cut.read_bytes()[:-7])
    assert not io.is_complete(cut)
    again = run_batch(pairs, out, max_disparity=8, ply=True, fill=True)
    assert again.done == ["pair00"] and again.skipped == ["pair01"]
    assert io.is_complete(cut)
    # the cloud is a recorded option: resuming without it over its outputs is refused
    with pytest.raises(ValueError, match="other options: .*ply"):
        run_batch(pairs, out, max_disparity=8, fill=True)


def test_batch_ply_and_depth_on_dask_equal_serial(calib_pairs, tmp_path, dask_client):
    pairs = find_pairs(calib_pairs)[:2]
    calib = Calibration(focal=400, baseline=50, cx=20, cy=12)
    kwargs = {"max_disparity": 8, "depth": True, "ply": True, "calibration": calib}
    serial = run_batch(pairs, tmp_path / "serial", **kwargs)
    parallel = run_batch(pairs, tmp_path / "dask", client=dask_client, **kwargs)
    assert serial.done == parallel.done == ["pair00", "pair01"]
    for pair in pairs:
        assert (tmp_path / "dask" / "cloud" / f"{pair.name}.ply").read_bytes() == (
            expected_cloud(pair, calib, tmp_path, max_disparity=8)
        )
        for where in (output_path, depth_path, cloud_path):
            a, b = where(tmp_path / "serial", pair), where(tmp_path / "dask", pair)
            assert a.read_bytes() == b.read_bytes()


def test_cli_batch_ply(calib_pairs, tmp_path):
    out = tmp_path / "out"
    args = ["batch", str(calib_pairs), "-o", str(out), "--max-disparity", "8", "-q"]
    result, calib = batch_with_one_calibration(calib_pairs, tmp_path, out, "--ply")
    assert result.exit_code == 0, result.output
    for pair in find_pairs(calib_pairs):
        assert (out / "cloud" / f"{pair.name}.ply").read_bytes() == expected_cloud(
            pair, calib, tmp_path, max_disparity=8
        )
    result = CliRunner().invoke(main, [*args[:3], str(tmp_path / "x"), *args[4:], "--calib",
                                       str(tmp_path / "all.txt")])  # fmt: skip
    lines = result.output.strip().splitlines()
    assert result.exit_code == 1 and lines == ["Error: --calib is used only with --depth or --ply"]


def test_is_complete_reads_a_ply_files_header(tmp_path):
    path = tmp_path / "c.ply"
    rng = np.random.default_rng(0)
    points = rng.random((10, 3))
    for colors in (None, rng.integers(0, 256, (10, 3), dtype=np.uint8)):
        io.write_ply(path, points, colors)
        assert io.is_complete(path)
        whole = path.read_bytes()
        for broken in (whole[:-1], whole + b"x", whole.replace(b"vertex 10", b"vertex 11"),
                       whole.replace(b"binary_little_endian", b"ascii"),
                       whole.replace(b"float x", b"quad x"), whole.replace(b"end_header", b"x"),
                       b"", b"ply\n"):  # fmt: skip
            path.write_bytes(broken)
            assert not io.is_complete(path), broken[:80]
    io.write_ply(path, np.empty((0, 3)))
    assert io.is_complete(path)


def test_subpixel_is_a_recorded_option_that_older_folders_lack(pairs_dir, tmp_path):
    import json

    pairs = find_pairs(pairs_dir)[:2]
    out = tmp_path / "out"
    # the older folders were made by dc (sgm, the default now, refines by default)
    run_batch(pairs, out, max_disparity=MAX_DISPARITY, method="dc")
    recorded = json.loads((out / "batch.json").read_text())
    assert recorded["subpixel"] is None
    # a batch.json written before the option existed resumes as made without it
    del recorded["subpixel"]
    (out / "batch.json").write_text(json.dumps(recorded))
    again = run_batch(pairs, out, max_disparity=MAX_DISPARITY, method="dc")
    assert again.skipped == [p.name for p in pairs]
    with pytest.raises(ValueError, match=r"other options: subpixel None \(now equiangular\)"):
        run_batch(pairs, out, max_disparity=MAX_DISPARITY, method="dc", subpixel="equiangular")
    # from the command line, the refined maps
    fine = tmp_path / "fine"
    args = ["batch", str(pairs_dir), "-o", str(fine), "--max-disparity", str(MAX_DISPARITY)]
    result = CliRunner().invoke(main, [*args, "--subpixel", "parabola", "-q"])
    assert result.exit_code == 0, result.output
    for pair in pairs:
        expected = match(io.read_image(pair.left), io.read_image(pair.right),
                         max_disparity=MAX_DISPARITY, subpixel="parabola")  # fmt: skip
        np.testing.assert_array_equal(
            io.read_pfm(output_path(fine, pair)), np.nan_to_num(expected.disparity, nan=np.inf)
        )


def test_median_is_a_recorded_option_that_older_folders_lack(pairs_dir, tmp_path):
    import json

    pairs = find_pairs(pairs_dir)[:2]
    out = tmp_path / "out"
    run_batch(pairs, out, max_disparity=MAX_DISPARITY, method="dc")
    recorded = json.loads((out / "batch.json").read_text())
    assert recorded["median"] == 0
    # as written before median, subpixel and the options of sgm
    for name in ("median", "subpixel", "census_window", "p1", "p2", "paths", "lr_tolerance"):
        del recorded[name]
    (out / "batch.json").write_text(json.dumps(recorded))
    skipped = run_batch(pairs, out, max_disparity=MAX_DISPARITY, method="dc").skipped
    assert skipped == [p.name for p in pairs]
    with pytest.raises(ValueError, match=r"other options: median 0 \(now 5\)"):
        run_batch(pairs, out, max_disparity=MAX_DISPARITY, median=5, method="dc")
    filtered = tmp_path / "filtered"
    args = ["batch", str(pairs_dir), "-o", str(filtered), "--max-disparity", str(MAX_DISPARITY)]
    result = CliRunner().invoke(main, [*args, "--median", "5", "--method", "dc", "-q"])
    assert result.exit_code == 0, result.output
    for pair in pairs:
        expected = match(io.read_image(pair.left), io.read_image(pair.right),
                         max_disparity=MAX_DISPARITY, median=5, method="dc")  # fmt: skip
        np.testing.assert_array_equal(
            io.read_pfm(output_path(filtered, pair)), np.nan_to_num(expected.disparity, nan=np.inf)
        )


def test_batch_confidence_here_and_on_dask(pairs_dir, tmp_path, dask_client):
    from dcstereo.batch.folders import confidence_path
    from dcstereo.refine.confidence import confidence

    pairs = find_pairs(pairs_dir)[:3]
    serial = run_batch(pairs, tmp_path / "serial", max_disparity=MAX_DISPARITY, confidence=True)
    parallel = run_batch(pairs, tmp_path / "dask", max_disparity=MAX_DISPARITY,
                         confidence=True, client=dask_client)  # fmt: skip
    assert serial.done == parallel.done == [p.name for p in pairs]
    for pair in pairs:
        left, right = io.read_image(pair.left), io.read_image(pair.right)
        expected = confidence(match(left, right, max_disparity=MAX_DISPARITY), left, right)
        written = io.read_pfm(confidence_path(tmp_path / "serial", pair))
        np.testing.assert_array_equal(written, np.nan_to_num(expected, nan=np.inf))
        other = confidence_path(tmp_path / "dask", pair).read_bytes()
        assert other == confidence_path(tmp_path / "serial", pair).read_bytes()
    # complete only with it; recorded, so resuming without it is refused
    confidence_path(tmp_path / "serial", pairs[1]).unlink()
    again = run_batch(pairs, tmp_path / "serial", max_disparity=MAX_DISPARITY, confidence=True)
    assert again.done == [pairs[1].name] and len(again.skipped) == 2
    with pytest.raises(ValueError, match="other options: confidence"):
        run_batch(pairs, tmp_path / "serial", max_disparity=MAX_DISPARITY)
    with pytest.raises(TypeError, match="confidence must be a bool, got 1"):
        run_batch(pairs, tmp_path / "x", max_disparity=MAX_DISPARITY, confidence=1)
    # the CLI flag
    out = tmp_path / "cli"
    args = ["batch", str(pairs_dir), "-o", str(out), "--max-disparity", str(MAX_DISPARITY)]
    result = CliRunner().invoke(main, [*args, "--confidence", "-q"])
    assert result.exit_code == 0, result.output
    assert len(list((out / "confidence").glob("*.pfm"))) == len(find_pairs(pairs_dir))


def test_stage_options_are_assumed_off_in_older_folders(pairs_dir, tmp_path):
    # a batch.json written before sgm's stages on request were recorded (census_smoothing
    # among them) resumes as made with them off, and refuses them on
    import json

    from dcstereo.batch.folders import ASSUMED_OPTIONS

    pairs = find_pairs(pairs_dir)[:2]
    out = tmp_path / "out"
    run_batch(pairs, out, max_disparity=MAX_DISPARITY, method="dc")
    recorded = json.loads((out / "batch.json").read_text())
    stages = ("planes", "aggregation", "cross_limit", "cross_tau", "cross_iterations",
              "census_step", "photometric", "census_smoothing", "row_alignment",
              "edges")  # fmt: skip
    for name in stages:
        assert recorded[name] == ASSUMED_OPTIONS[name], name
        del recorded[name]
    (out / "batch.json").write_text(json.dumps(recorded))
    skipped = run_batch(pairs, out, max_disparity=MAX_DISPARITY, method="dc").skipped
    assert skipped == [p.name for p in pairs]
    with pytest.raises(ValueError, match=r"census_smoothing 0.0 \(now 1.2\)"):
        run_batch(pairs, out, max_disparity=MAX_DISPARITY, census_smoothing=1.2)
    with pytest.raises(ValueError, match=r"row_alignment None \(now estimated\)"):
        run_batch(pairs, out, max_disparity=MAX_DISPARITY, row_alignment="estimated")
    with pytest.raises(ValueError, match=r"edges None \(now support-weights\)"):
        run_batch(pairs, out, max_disparity=MAX_DISPARITY, edges="support-weights")
