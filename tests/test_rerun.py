"""Rerun recordings of results, read back with rerun's own API (the entities and shapes)."""

import logging
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner
from PIL import Image

import dcstereo
from dcstereo import io, viz
from dcstereo.cli import main
from dcstereo.evaluation.synthetic import synthetic_sequence
from dcstereo.geometry import Calibration, depth, point_cloud
from dcstereo.refine.confidence import confidence
from dcstereo.result import FLAG_BORDER, FLAG_MISMATCH, FLAG_OCCLUDED

rr = pytest.importorskip("rerun")

RIG = "cam0=[200 0 31.5; 0 210 11.5; 0 0 1]\nbaseline=60\ndoffs=1\n"
CALIBRATION = Calibration(focal=200.0, baseline=60.0, cx=31.5, cy=11.5, doffs=1.0, focal_y=210.0)
IMAGES = {"world/camera/image", "disparity", "occlusion", "confidence"}
GEOMETRY = {"world", "world/camera", "world/camera/depth", "world/points"}

# Rerun's channel datatypes (rerun.datatypes.ChannelDatatype): byte sizes of those used here
_BYTES = {6: 1, 7: 2, 33: 4, 34: 4, 35: 8}


def read_recording(path):
    """``{entity: {column: [(frame or None, value), ...]}}`` of an .rrd file."""
    entities = {}
    for chunk in rr.chunk.RrdReader(path).stream().to_chunks():
        batch = chunk.to_record_batch()
        columns = entities.setdefault(chunk.entity_path.lstrip("/"), {})
        frames = batch.column("frame").to_pylist() if "frame" in batch.schema.names else None
        for name in batch.schema.names:
            if name in ("frame", "log_time", "rerun.controls.RowId"):
                continue
            values = batch.column(name).to_pylist()
            for row, value in enumerate(values):
                columns.setdefault(name, []).append(
                    (None if frames is None else frames[row], value)
                )
    for columns in entities.values():
        for values in columns.values():
            values.sort(key=lambda item: -1 if item[0] is None else item[0])
    return entities


def image_of(entities, entity, kind="Image", row=-1):
    """Decode the image logged at ``entity`` (row ``row``) into a numpy array."""
    columns = entities[entity]
    fmt = columns[f"{kind}:format"][row][1][0]
    data = bytes(columns[f"{kind}:buffer"][row][1][0])
    width, height, size = fmt["width"], fmt["height"], _BYTES[fmt["channel_datatype"]]
    channels = len(data) // (width * height * size)
    dtype = {1: np.uint8, 2: np.uint16, 4: np.float32, 8: np.float64}[size]
    if fmt["channel_datatype"] == 7:
        dtype = np.uint16
    array = np.frombuffer(data, dtype=dtype).reshape(height, width, channels)
    return array[:, :, 0] if channels == 1 else array


@pytest.fixture(scope="module")
def matched():
    frame = synthetic_sequence(1, height=24, width=64, seed=3)[0]
    result = dcstereo.match(frame.left, frame.right, max_disparity=12)
    return frame.left, frame.right, result


def test_log_rerun_entities_and_shapes(matched, tmp_path):
    left, right, result = matched
    sure = confidence(result, left, right)
    path = tmp_path / "one.rrd"
    with viz.rerun_recording(path) as recording:
        viz.log_rerun(result, left, recording=recording, calibration=CALIBRATION,
                      confidence=sure, frame=7, meter=1000.0)  # fmt: skip
    entities = read_recording(path)
    assert IMAGES | GEOMETRY <= set(entities)
    height, width = result.disparity.shape
    np.testing.assert_array_equal(image_of(entities, "world/camera/image"), left)
    disparity = image_of(entities, "disparity")
    assert disparity.shape == (height, width, 3) and disparity.dtype == np.uint8
    np.testing.assert_array_equal(disparity, viz.colorize(result.disparity, vmin=0, vmax=12))
    assert image_of(entities, "confidence").shape == (height, width, 3)
    # the occlusion classes: 1 occluded, 2 beyond the border, 3 a mismatch (sgm's
    # left-right check), 0 an estimate
    classes = image_of(entities, "occlusion", "SegmentationImage")
    expected = np.zeros((height, width), dtype=np.uint8)
    expected[(result.flags & FLAG_OCCLUDED) != 0] = 1
    expected[(result.flags & FLAG_MISMATCH) != 0] = 3
    expected[(result.flags & FLAG_BORDER) != 0] = 2
    np.testing.assert_array_equal(classes, expected)
    assert {1, 2, 3} <= set(np.unique(classes))
    labels = entities["occlusion"]["AnnotationContext:context"][0][1][0]
    assert [entry["class_description"]["info"]["label"] for entry in labels] == [
        "estimate", "occluded", "border", "mismatch",
    ]  # fmt: skip
    # the depth in the baseline's unit, 0 where there is none, and its meter
    z = image_of(entities, "world/camera/depth", "DepthImage")
    np.testing.assert_allclose(z, np.nan_to_num(depth(result.disparity, CALIBRATION)), rtol=1e-6)
    assert entities["world/camera/depth"]["DepthImage:meter"][0][1] == [1000.0]
    # the camera from the calibration (Rerun stores the matrix column by column)
    pinhole = entities["world/camera"]
    matrix = np.array(pinhole["Pinhole:image_from_camera"][0][1][0]).reshape(3, 3).T
    np.testing.assert_allclose(matrix, [[200, 0, 31.5], [0, 210, 11.5], [0, 0, 1]])
    assert pinhole["Pinhole:resolution"][0][1][0] == [width, height]
    # the coloured cloud, in metres
    cloud = point_cloud(result.disparity, CALIBRATION, left)
    points = np.array(entities["world/points"]["Points3D:positions"][0][1])
    assert points.shape == (len(cloud), 3)
    np.testing.assert_allclose(points, cloud.points / 1000.0, rtol=1e-6)
    colors = np.array(entities["world/points"]["Points3D:colors"][0][1], dtype=np.uint32)
    np.testing.assert_array_equal(colors >> 24, cloud.colors[:, 0])  # 0xRRGGBBAA
    # every entity logged at frame 7 but the static ones
    frames = {
        entity: sorted({f for values in entities[entity].values() for f, _ in values}, key=str)
        for entity in IMAGES | GEOMETRY
    }
    assert frames == {
        **{entity: [7] for entity in IMAGES | GEOMETRY - {"world"}},
        "world": [None],
        "occlusion": [7, None],  # its labels are static
    }


def test_features_of_dc_are_points_on_the_image(matched, tmp_path):
    left, right, _ = matched
    result = dcstereo.match(left, right, max_disparity=12, method="dc")
    assert len(result.features)
    with viz.rerun_recording(tmp_path / "f.rrd") as recording:
        viz.log_rerun(result, left, recording=recording)
    entities = read_recording(tmp_path / "f.rrd")
    points = np.array(entities["world/camera/image/features"]["Points2D:positions"][0][1])
    np.testing.assert_allclose(points, result.features[:, [1, 0]] + 0.5)


def test_without_a_calibration_no_geometry(matched, tmp_path):
    left, _, result = matched
    with viz.rerun_recording(tmp_path / "plain.rrd") as recording:
        viz.log_rerun(result.disparity, recording=recording, frame=0)
    entities = read_recording(tmp_path / "plain.rrd")
    assert {"disparity", "occlusion"} <= set(entities)
    assert not (GEOMETRY | {"world/camera/image", "confidence"}) & set(entities)
    # a map alone: its NaN pixels are the occluded ones, its range the colour map's
    classes = image_of(entities, "occlusion", "SegmentationImage")
    np.testing.assert_array_equal(classes, np.isnan(result.disparity).astype(np.uint8))
    np.testing.assert_array_equal(image_of(entities, "disparity"), viz.colorize(result.disparity))


def test_frames_on_a_time_line(matched, tmp_path):
    left, _, result = matched
    with viz.rerun_recording(tmp_path / "seq.rrd") as recording:
        for index in (0, 1, 2):
            viz.log_rerun(result, left, recording=recording, frame=index, timeline="frame")
    entities = read_recording(tmp_path / "seq.rrd")
    assert [f for f, _ in entities["disparity"]["Image:buffer"]] == [0, 1, 2]


def test_the_recording_is_its_own_and_written_atomically(matched, tmp_path):
    _, _, result = matched
    path = tmp_path / "never.rrd"
    with pytest.raises(RuntimeError, match="stop"):
        with viz.rerun_recording(path) as recording:
            viz.log_rerun(result, recording=recording)
            assert rr.get_global_data_recording() is None  # rerun's global one untouched
            raise RuntimeError("stop")
    assert list(tmp_path.iterdir()) == []


def test_log_rerun_uses_the_current_recording_or_says_there_is_none(matched, tmp_path):
    _, _, result = matched
    with pytest.raises(ValueError, match="no Rerun recording: pass recording="):
        viz.log_rerun(result)
    recording = rr.RecordingStream("dcstereo-test")
    recording.save(tmp_path / "current.rrd")
    with recording:  # rerun's own way to make a recording the current one
        viz.log_rerun(result, frame=0)
    recording.flush()
    recording.disconnect()
    assert "disparity" in read_recording(tmp_path / "current.rrd")


@pytest.mark.parametrize(
    ("kwargs", "error", "message"),
    [
        ({"left": np.zeros((3, 3), np.uint8)}, ValueError, "left has shape"),
        ({"confidence": np.zeros((3, 3))}, ValueError, "confidence has shape"),
        ({"occluded": np.zeros((24, 64), bool)}, ValueError, "occluded is given by the result"),
        ({"calibration": {"focal": 1}}, TypeError, "calibration must be a dcstereo"),
        ({"frame": 1.5}, TypeError, "frame must be an integer"),
        ({"meter": 0}, ValueError, "meter must be positive"),
        ({"recording": "rec.rrd"}, TypeError, "recording must be a rerun.RecordingStream"),
        ({"timeline": ""}, ValueError, "timeline must be a non-empty name"),
    ],
)
def test_log_rerun_bad_arguments(matched, kwargs, error, message):
    _, _, result = matched
    with pytest.raises(error, match=message):
        viz.log_rerun(result, **kwargs)


def test_rerun_recording_bad_arguments(tmp_path):
    with pytest.raises(ValueError, match="an .rrd file"):
        with viz.rerun_recording(tmp_path / "x.png"):
            pass
    with pytest.raises(ValueError, match="a path .* or spawn=True"):
        with viz.rerun_recording():
            pass
    with pytest.raises(ValueError, match="does not exist"):
        with viz.rerun_recording(tmp_path / "no" / "x.rrd"):
            pass


def test_without_rerun_installed_the_error_names_the_extra(monkeypatch, matched):
    monkeypatch.setitem(sys.modules, "rerun", None)  # import rerun now fails
    with pytest.raises(ImportError, match=r'pip install "dcstereo\[rerun\]"'):
        viz.log_rerun(matched[2])
    with pytest.raises(ImportError, match=r"dcstereo\[rerun\]"):
        with viz.rerun_recording("x.rrd"):
            pass


def test_the_library_imports_and_matches_without_the_extras():
    code = """
import sys
sys.modules["rerun"] = None
sys.modules["cv2"] = None
import numpy as np
import dcstereo, dcstereo.viz, dcstereo.cli, dcstereo.batch.video
rng = np.random.default_rng(0)
right = rng.integers(0, 256, (16, 40), dtype=np.uint8)
left = np.roll(right, 3, axis=1)
fixed = dcstereo.StereoDC.create(numDisparities=8).compute(left, right)
assert fixed.dtype == np.int16
try:
    dcstereo.viz.log_rerun(dcstereo.match(left, right, max_disparity=7))
except ImportError as err:
    print(err)
"""
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=False)
    assert done.returncode == 0, done.stderr
    assert 'install the extra: pip install "dcstereo[rerun]"' in done.stdout


# --- the command line --------------------------------------------------------------------


@pytest.fixture
def pair_files(tmp_path, matched):
    left, right, _ = matched
    Image.fromarray(left).save(tmp_path / "left.png")
    Image.fromarray(right).save(tmp_path / "right.png")
    (tmp_path / "calib.txt").write_text(RIG)
    return tmp_path


def invoke(*args):
    return CliRunner().invoke(main, [str(a) for a in args], catch_exceptions=False)


def test_run_rerun_with_a_calibration(pair_files, matched):
    folder = pair_files
    left, right, result = matched
    out = folder / "run.rrd"
    done = invoke("run", folder / "left.png", folder / "right.png", "-o", folder / "d.pfm",
                  "--max-disparity", 12, "--calib", folder / "calib.txt",
                  "--rerun", out)  # fmt: skip
    assert done.exit_code == 0, done.output
    assert f"Rerun recording -> {out}" in done.output
    entities = read_recording(out)
    assert IMAGES | GEOMETRY <= set(entities)
    assert [f for f, _ in entities["disparity"]["Image:buffer"]] == [0]
    z = image_of(entities, "world/camera/depth", "DepthImage")
    calibration = Calibration.from_middlebury(folder / "calib.txt")
    np.testing.assert_allclose(z, np.nan_to_num(depth(result.disparity, calibration)), rtol=1e-6)
    np.testing.assert_allclose(
        image_of(entities, "confidence"),
        viz.colorize(confidence(result, left, right), vmin=0.0, vmax=1.0, cmap="viridis"),
    )
    assert not [p.name for p in folder.iterdir() if p.name.startswith(".")]  # no temporaries


def test_run_rerun_without_a_calibration(pair_files):
    folder = pair_files
    out = folder / "plain.rrd"
    done = invoke("run", folder / "left.png", folder / "right.png", "-o", folder / "d.pfm",
                  "--max-disparity", 12, "--rerun", out, "-q")  # fmt: skip
    assert done.exit_code == 0, done.output
    entities = read_recording(out)
    assert IMAGES <= set(entities) and not GEOMETRY & set(entities)


@pytest.mark.parametrize(
    ("extra", "message"),
    [
        (["--rerun", "out.png"], "--rerun 'out.png': unsupported suffix '.png', use .rrd"),
        (["--rerun", "no/where.rrd"], "directory 'no' does not exist"),
        (["--rerun", "left.png"], "is the left input"),
        (["--focal", 9, "--baseline", 1], "is used only with --depth-out, --ply or --rerun"),
    ],
)
def test_run_rerun_errors_are_one_line(pair_files, monkeypatch, extra, message):
    monkeypatch.chdir(pair_files)
    done = invoke("run", "left.png", "right.png", "-o", "d.pfm", "--max-disparity", 12, *extra)
    assert done.exit_code == 1 and message in done.output, done.output
    assert done.output.count("\n") == 1 and not Path("d.pfm").exists()


def test_run_rerun_without_rerun_installed(pair_files, monkeypatch):
    monkeypatch.setitem(sys.modules, "rerun", None)
    folder = pair_files
    done = invoke("run", folder / "left.png", folder / "right.png", "-o", folder / "d.pfm",
                  "--max-disparity", 12, "--rerun-spawn")  # fmt: skip
    assert done.exit_code == 1 and done.output.count("\n") == 1
    assert (
        'need Rerun: Rerun is not installed; install the extra: pip install "dcstereo[rerun]"'
        in (done.output)
    )
    assert not (folder / "d.pfm").exists()


@pytest.fixture
def fake_viewer(monkeypatch, tmp_path):
    """A stand-in for the spawned viewer (none can run here): a file the stream goes to."""
    calls = []

    def viewer_sink(rerun, recording):
        calls.append(recording)
        return rerun.FileSink(str(tmp_path / "viewer.rrd"))

    monkeypatch.setattr(viz, "_viewer_sink", viewer_sink)
    return tmp_path / "viewer.rrd", calls


def test_run_rerun_spawn_streams_to_the_viewer(pair_files, fake_viewer):
    # Only the option's parsing and the stream can be tested headless: the viewer's own
    # start (rerun.spawn) is replaced by a file sink.
    viewer, calls = fake_viewer
    folder = pair_files
    done = invoke("run", folder / "left.png", folder / "right.png", "-o", folder / "d.pfm",
                  "--max-disparity", 12, "--rerun-spawn",
                  "--rerun", folder / "also.rrd")  # fmt: skip
    assert done.exit_code == 0, done.output
    assert len(calls) == 1
    assert IMAGES <= set(read_recording(viewer)) and IMAGES <= set(
        read_recording(folder / "also.rrd")
    )
    viewer.unlink()
    done = invoke("run", folder / "left.png", folder / "right.png", "-o", folder / "e.pfm",
                  "--max-disparity", 12, "--rerun-spawn", "-q")  # fmt: skip
    assert done.exit_code == 0, done.output
    assert len(calls) == 2 and IMAGES <= set(read_recording(viewer))


def test_a_viewer_that_went_away_is_a_warning(matched, tmp_path, monkeypatch, caplog):
    def unreachable(rerun, recording):
        return rerun.GrpcSink("rerun+http://127.0.0.1:9/proxy")  # nothing listens there

    monkeypatch.setattr(viz, "_viewer_sink", unreachable)
    with caplog.at_level(logging.WARNING, logger="dcstereo.viz"):
        with viz.rerun_recording(tmp_path / "kept.rrd", spawn=True) as recording:
            viz.log_rerun(matched[2], recording=recording)
    assert "the Rerun viewer could not be reached" in caplog.text
    assert "disparity" in read_recording(tmp_path / "kept.rrd")


@pytest.fixture(scope="module")
def sequence(tmp_path_factory):
    root = tmp_path_factory.mktemp("rerun-sequence")
    frames = synthetic_sequence(3, height=24, width=64, seed=5)
    for side in ("left", "right"):
        (root / side).mkdir()
        for i, frame in enumerate(frames):
            io.write_rgb_png(root / side / f"{i:03d}.png", getattr(frame, side))
    (root / "calib.txt").write_text(RIG)
    return root, frames


def test_video_rerun_logs_every_frame(sequence, tmp_path):
    root, frames = sequence
    out = tmp_path / "seq.rrd"
    args = ["video", root / "left", root / "right", "-o", tmp_path / "out", "--max-disparity",
            12, "--calib", root / "calib.txt", "--rerun", out]  # fmt: skip
    done = invoke(*args)
    assert done.exit_code == 0, done.output
    assert f"Rerun recording {out} (3 frames)" in done.output
    entities = read_recording(out)
    assert IMAGES | GEOMETRY <= set(entities)
    for entity in ("world/camera/image", "disparity", "confidence"):
        assert [f for f, _ in entities[entity]["Image:buffer"]] == [0, 1, 2]
    for i, frame in enumerate(frames):
        np.testing.assert_array_equal(image_of(entities, "world/camera/image", row=i), frame.left)
        expected = dcstereo.match(frame.left, frame.right, max_disparity=12).disparity
        np.testing.assert_array_equal(
            image_of(entities, "disparity", row=i), viz.colorize(expected, vmin=0, vmax=12)
        )
    # no confidence files unless asked for: the viewer's maps are not outputs
    assert not list((tmp_path / "out").glob("*confidence*"))
    # a rerun resumes: the frames already complete are not logged again
    again = invoke(*args)
    assert again.exit_code == 0 and f"Rerun recording {out} (0 frames)" in again.output
    assert "disparity" not in read_recording(out)
    assert invoke(*args, "--no-resume").exit_code == 0
    assert len(read_recording(out)["disparity"]["Image:buffer"]) == 3


def test_video_rerun_errors(sequence, tmp_path):
    root, _ = sequence
    base = ["video", root / "left", root / "right", "-o", tmp_path / "out", "--max-disparity", 12]
    done = invoke(*base, "--rerun", tmp_path / "out" / "seq.rrd")
    assert done.exit_code == 1 and "does not exist" in done.output
    assert not (tmp_path / "out").exists()
    done = invoke(*base, "--rerun", tmp_path / "seq.mp4")
    assert done.exit_code == 1 and "unsupported suffix '.mp4', use .rrd" in done.output


def test_video_rerun_on_dask_logs_the_same_frames(sequence, tmp_path):
    distributed = pytest.importorskip("distributed")
    from dcstereo.batch.video import match_sequence, open_sequence

    root, frames = sequence
    calibration = Calibration.from_middlebury(root / "calib.txt")
    with (
        distributed.LocalCluster(
            n_workers=1, processes=False, threads_per_worker=1, dashboard_address=":0"
        ) as cluster,
        distributed.Client(cluster) as client,
        viz.rerun_recording(tmp_path / "dask.rrd") as recording,
    ):
        report = match_sequence(
            open_sequence(root / "left", root / "right"),
            tmp_path / "out",
            max_disparity=12,
            client=client,
            calibration=calibration,
            recording=recording,
        )
    assert report.ok and len(report.done) == 3
    entities = read_recording(tmp_path / "dask.rrd")
    assert IMAGES | GEOMETRY <= set(entities)
    assert [f for f, _ in entities["world/camera/image"]["Image:buffer"]] == [0, 1, 2]
    for i, frame in enumerate(frames):
        np.testing.assert_array_equal(image_of(entities, "world/camera/image", row=i), frame.left)


def test_a_viewer_that_cannot_start_is_a_one_line_error(pair_files, monkeypatch):
    def no_viewer(**kwargs):
        raise RuntimeError('Failed to find Rerun Viewer executable at "rerun"')

    monkeypatch.setattr(rr, "spawn", no_viewer)
    folder = pair_files
    done = invoke("run", folder / "left.png", folder / "right.png", "-o", folder / "d.pfm",
                  "--max-disparity", 12, "--rerun-spawn", "--rerun", folder / "r.rrd")  # fmt: skip
    assert done.exit_code == 1 and done.output.count("\n") == 1, done.output
    assert "Error: cannot start the Rerun viewer: Failed to find" in done.output
    assert not (folder / "d.pfm").exists() and not (folder / "r.rrd").exists()
    assert not [p for p in folder.iterdir() if p.name.startswith(".")]
