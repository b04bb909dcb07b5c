"""Edge and bad inputs of the library's public functions (io, viz, datasets, explore,
synthetic, opencv, batch, video): one clear error naming the problem, no hang, no
warning, no garbage and nothing half-written."""

import json
import os
import threading

import numpy as np
import pytest
from PIL import Image

from dcstereo import io, viz
from dcstereo.batch.folders import Pair, find_pairs, run_batch
from dcstereo.evaluation import datasets
from dcstereo.evaluation.synthetic import synthetic_sequence
from dcstereo.result import DisparityResult
from dcstereo.viz import explore


def _listing(directory):
    return sorted(p.name for p in directory.iterdir())


def _pair(height=16, width=32, shift=2, seed=0):
    rng = np.random.default_rng(seed)
    right = rng.integers(0, 256, (height, width), dtype=np.uint8)
    return np.roll(right, shift, axis=1), right


# --- io -------------------------------------------------------------------------------


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="needs named pipes")
@pytest.mark.parametrize("name", ["out.pfm", "out.png"])
def test_is_complete_does_not_block_on_a_named_pipe(tmp_path, name):
    fifo = tmp_path / name
    os.mkfifo(fifo)
    answer = []
    worker = threading.Thread(target=lambda: answer.append(io.is_complete(fifo)), daemon=True)
    worker.start()
    worker.join(10)
    blocked = worker.is_alive()
    if blocked:  # release the reader: open the pipe's other end
        with open(fifo, "wb"):
            pass
        worker.join(10)
    assert not blocked, "is_complete blocked reading a named pipe"
    assert answer == [False]


@pytest.mark.parametrize(
    ("row", "shown"),
    [
        ([np.nan, 1, 2, 0.5, 1], "nan, 1, 2"),
        ([1, np.inf, 2, 0.5, 1], "1, inf, 2"),
        ([1, 2, 2.5, 0, 0], "1, 2, 2.5"),
    ],
)
def test_write_features_csv_refuses_pixel_columns_that_are_not_integers(tmp_path, row, shown):
    table = np.array([[0, 3, 1, 2.0, 1.0], row], dtype=np.float64)
    with pytest.raises(ValueError, match=rf"feature 1: .* finite integers, got {shown}$"):
        io.write_features_csv(tmp_path / "f.csv", table)
    assert _listing(tmp_path) == []


def test_write_features_csv_refuses_text(tmp_path):
    with pytest.raises(TypeError, match="features must hold numbers"):
        io.write_features_csv(tmp_path / "f.csv", [["a", 1, 2, 3, 4]])
    assert _listing(tmp_path) == []


def test_features_csv_without_features_reads_back_without_a_warning(tmp_path):
    path = tmp_path / "f.csv"
    io.write_features_csv(path, np.empty((0, 5)))
    back = io.read_features_csv(path)  # the suite turns warnings into errors
    assert back.shape == (0, 5)


@pytest.mark.parametrize("size", [b"1_0 1", b"+2 1"])
def test_pfm_header_sizes_must_be_plain_digits(tmp_path, size):
    path = tmp_path / "odd.pfm"
    path.write_bytes(b"Pf\n" + size + b"\n-1.0\n" + b"\0" * 80)
    with pytest.raises(ValueError, match="malformed width, height or scale"):
        io.read_pfm(path)
    assert not io.is_complete(path)


# --- viz ------------------------------------------------------------------------------


def test_colorize_limits_near_the_ends_of_float64():
    middle = viz.colorize(np.array([[0.0, 0.5, 1.0]]))[0, 1]
    out = viz.colorize(np.array([[1.0, 5.0]]), vmin=-1.7e308, vmax=1.7e308)
    np.testing.assert_array_equal(out[0], [middle, middle])
    ends = viz.colorize(np.array([[0.0, 1.0]]))[0]
    huge = viz.colorize(np.array([[-1.7e308, 1.7e308]]))[0]
    np.testing.assert_array_equal(huge, ends)


def test_error_map_error_beyond_float64_is_bad_without_a_warning():
    out = viz.error_map(np.array([[1.7e308, 1.0]]), np.array([[-1.7e308, 1.0]]))
    np.testing.assert_array_equal(out[0], [viz.ERROR_BAD, viz.ERROR_GOOD])


def test_draw_points_huge_radius_and_far_points():
    image = np.zeros((3, 4), np.uint8)
    # A radius far larger than the image: a square reaching it from outside covers it.
    out = viz.draw_points(image, [-500], [1], color=(9, 8, 7), radius=10**6)
    assert (out == [9, 8, 7]).all()
    # Points far away draw nothing, with no cast warning.
    out = viz.draw_points(image, [1e300, -1e300, 1], [1, 1, 1e300], radius=2)
    assert not out.any()


def test_draw_points_text_coordinates_are_a_type_error():
    with pytest.raises(TypeError, match="xs and ys must hold numbers"):
        viz.draw_points(np.zeros((3, 3), np.uint8), ["a"], [1])


# --- datasets -------------------------------------------------------------------------


def _v2_scene(folder, meta=None):
    rng = np.random.default_rng(0)
    folder.mkdir(parents=True)
    for name in ("left.png", "right.png"):
        Image.fromarray(rng.integers(0, 256, (5, 6, 3), dtype=np.uint8)).save(folder / name)
    Image.fromarray(np.full((5, 6), 8, np.uint8)).save(folder / "disp_gt.png")
    for name in datasets.MIDDLEBURY_MASKS.values():
        Image.fromarray(np.full((5, 6), 255, np.uint8)).save(folder / name)
    text = json.dumps({"scale": 4, "ndisp": 8}) if meta is None else meta
    (folder / "meta.json").write_text(text)
    return folder


def _truncated_png(path):
    noise = np.random.default_rng(1).integers(0, 256, (64, 64), dtype=np.uint8)
    Image.fromarray(noise).save(path)
    data = path.read_bytes()
    return data[: len(data) // 2]


@pytest.mark.parametrize(
    ("file", "damage", "reason"),
    [
        ("left.png", lambda path: b"not an image", "not a recognised image format"),
        ("nonocc.png", lambda path: b"", "not a recognised image format"),
        ("disp_gt.png", _truncated_png, "truncated or corrupt image data"),
    ],
)
def test_damaged_scene_image_names_the_file(tmp_path, file, damage, reason):
    folder = _v2_scene(tmp_path / "scene")
    path = folder / file
    path.write_bytes(damage(path))
    with pytest.raises(ValueError, match=rf"cannot read image '.*{file}': {reason}"):
        datasets.load_scene(folder)


@pytest.mark.parametrize("ndisp", ["Infinity", "1e400", "8.7"])
def test_meta_json_ndisp_must_be_a_whole_number(tmp_path, ndisp):
    folder = _v2_scene(tmp_path / "scene", meta=f'{{"scale": 4, "ndisp": {ndisp}}}')
    with pytest.raises(ValueError, match="must give a numeric 'scale' and an integer 'ndisp'"):
        datasets.load_middlebury(folder)


def test_meta_json_scale_beyond_float(tmp_path):
    folder = _v2_scene(tmp_path / "scene", meta='{"scale": 1' + "0" * 400 + ', "ndisp": 8}')
    with pytest.raises(ValueError, match="must give a numeric 'scale' and an integer 'ndisp'"):
        datasets.load_middlebury(folder)


def _2005_scene(folder):
    folder.mkdir()
    for name in ("view1.png", "view5.png"):
        Image.fromarray(np.zeros((370, 20, 3), np.uint8)).save(folder / name)
    Image.fromarray(np.full((370, 20), 30, np.uint8)).save(folder / "disp1.png")
    return folder


@pytest.mark.parametrize("scale", ["2", [2], True])
def test_2005_scale_of_the_wrong_type(tmp_path, scale):
    folder = _2005_scene(tmp_path / "art")
    with pytest.raises(TypeError, match="scale must be a number, got"):
        datasets.load_scene(folder, scale=scale)


def _2014_scene(folder, calib=b"ndisp=8\n"):
    folder.mkdir()
    for name in ("im0.png", "im1.png"):
        Image.fromarray(np.zeros((4, 20, 3), np.uint8)).save(folder / name)
    io.write_pfm(folder / "disp0GT.pfm", np.full((4, 20), 3.0))
    (folder / "calib.txt").write_bytes(calib)
    return folder


@pytest.mark.parametrize(
    ("calib", "message"),
    [
        (b"ndisp=inf\n", "must give an integer ndisp"),
        (b"ndisp=8.5\n", "must give an integer ndisp"),
        (b"\xff\xfendisp=8\n", "calib.txt: it is not UTF-8 text"),
    ],
)
def test_2014_bad_calib(tmp_path, calib, message):
    folder = _2014_scene(tmp_path / "m", calib)
    with pytest.raises(ValueError, match=message):
        datasets.load_scene(folder)


def test_2014_colour_right_truth_is_refused(tmp_path):
    folder = _2014_scene(tmp_path / "m")
    io.write_pfm(folder / "disp1.pfm", np.full((4, 20, 3), 3.0))
    with pytest.raises(ValueError, match=r"disp1\.pfm must be a gray \(Pf\) PFM file"):
        datasets.load_scene(folder)


def test_cross_check_of_maps_of_other_shapes():
    with pytest.raises(ValueError, match=r"one shape, got \(2, 2\) and \(2, 3\)"):
        datasets.cross_check(np.zeros((2, 2)), np.zeros((2, 3)), 1.0)


# --- explore --------------------------------------------------------------------------


@pytest.mark.parametrize("row", [5.0, "3", None, True])
def test_dsi_row_and_scanline_need_an_integer_row(row):
    left, right = _pair()
    with pytest.raises(TypeError, match="row must be an integer"):
        explore.dsi_row(left, right, row, max_disparity=4)
    with pytest.raises(TypeError, match="row must be an integer"):
        explore.scanline(left, right, row, max_disparity=4, methods=("block",))


def test_dsi_row_checks_the_range_like_match():
    left, right = _pair()
    with pytest.raises(TypeError, match="max_disparity must be an integer, got 4.5"):
        explore.dsi_row(left, right, 3, max_disparity=4.5)
    # refused, as match refuses it, not rows of NaN (a huge array for a huge range)
    with pytest.raises(ValueError, match="does not fit an image 32 pixels wide"):
        explore.dsi_row(left, right, 3, max_disparity=1000)


def test_scanline_methods_given_as_one_string():
    left, right = _pair()
    with pytest.raises(TypeError, match="got the string 'dsi3'"):
        explore.scanline(left, right, 3, max_disparity=4, methods="dsi3")
    with pytest.raises(TypeError, match="got the string 'dsi3'"):
        explore.compare_methods(left, right, max_disparity=4, methods="dsi3")


@pytest.mark.parametrize(
    ("size", "error"),
    [
        ({"width": 0}, ValueError),
        ({"width": 10**6, "height": 10**6}, ValueError),
        ({"width": 300.5}, TypeError),
    ],
)
def test_scanline_figure_size(size, error):
    left, right = _pair()
    data = explore.scanline(left, right, 3, max_disparity=4, methods=("block",))
    with pytest.raises(error, match="width|height"):
        explore.scanline_figure(data, **size)


def test_compare_figure_checks_results_and_scale():
    left, right = _pair()
    results = explore.compare_methods(left, right, max_disparity=4, methods=("block",))
    with pytest.raises(ValueError, match=r"results\['block'\] has shape \(16, 32\)"):
        explore.compare_figure(left[:, :20], results, max_disparity=4)
    with pytest.raises(TypeError, match=r"results\['x'\] must be a DisparityResult"):
        explore.compare_figure(left, {"x": 3}, max_disparity=4)
    with pytest.raises(ValueError, match="max_disparity must be a finite number 0 or more"):
        explore.compare_figure(left, results, max_disparity=-1)
    assert isinstance(results["block"], DisparityResult)


# --- synthetic ------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("kwargs", "error", "message"),
    [
        ({"background_disparity": (2.7, 4.2)}, TypeError, "background_disparity must be an"),
        ({"background_disparity": (2, 4, 5)}, TypeError, "a pair of integers"),
        ({"background_disparity": 3}, TypeError, "a pair of integers"),
        ({"foreground_disparity": 14.5}, TypeError, "foreground_disparity must be an integer"),
        ({"turn": float("nan")}, ValueError, "turn must be finite"),
        ({"turn": "x"}, TypeError, "turn must be a number"),
        ({"seed": -1}, ValueError, "seed must be 0 or more"),
        ({"seed": "x"}, TypeError, "seed must be an integer"),
    ],
)
def test_synthetic_sequence_bad_arguments(kwargs, error, message):
    with pytest.raises(error, match=message):
        synthetic_sequence(2, height=24, width=40, **kwargs)


# --- opencv ---------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"max_disparity": 79}, "do not fit OpenCV sgbm on an image 80 pixels wide"),
        ({"max_disparity": 64, "method": "bm"}, "do not fit OpenCV bm"),  # was garbage
        ({"max_disparity": 2**31}, "do not fit OpenCV sgbm"),
        ({"max_disparity": 8, "min_disparity": -100}, "must be at least -79"),
    ],
)
def test_opencv_ranges_it_cannot_search(kwargs, message):
    pytest.importorskip("cv2")
    from dcstereo.compat.opencv import match_opencv

    left, right = _pair(40, 80, 3)
    with pytest.raises(ValueError, match=message):
        match_opencv(left, right, **kwargs)


def test_opencv_numpy_integer_window():
    pytest.importorskip("cv2")
    from dcstereo.compat.opencv import match_opencv

    left, right = _pair(40, 80, 3)
    result = match_opencv(left, right, max_disparity=8, window=np.int64(5))
    assert result.params.window == 5 and type(result.params.window) is int


@pytest.mark.parametrize(
    ("kwargs", "error", "message"),
    [
        ({"p1": "x"}, TypeError, "p1 must be an integer, got 'x'"),
        ({"p2": 1.5}, TypeError, "p2 must be an integer, got 1.5"),
        ({"uniqueness_ratio": -1}, ValueError, "uniqueness_ratio must be at least 0"),
        ({"speckle_window": True}, TypeError, "speckle_window must be an integer"),
        ({"pre_filter_cap": 0}, ValueError, "pre_filter_cap must be at least 1"),
        ({"pre_filter_cap": 64, "method": "bm"}, ValueError, "pre_filter_cap must be 1 to 63"),
    ],
)
def test_opencv_options_are_named_when_wrong(kwargs, error, message):
    from dcstereo.compat.opencv import match_opencv

    left, right = _pair(40, 80, 3)
    with pytest.raises(error, match=message):
        match_opencv(left, right, max_disparity=8, **kwargs)  # checked before cv2 is needed


# --- batch ----------------------------------------------------------------------------


@pytest.fixture
def pair_folder(tmp_path):
    left, right = _pair()
    folder = tmp_path / "pairs" / "p0"
    folder.mkdir(parents=True)
    io.write_rgb_png(folder / "left.png", left)
    io.write_rgb_png(folder / "right.png", right)
    return folder.parent


@pytest.mark.parametrize(
    ("kwargs", "error", "message"),
    [
        ({"threads": 0}, ValueError, "threads must be at least 1, got 0"),
        ({"threads": 10**6}, ValueError, "threads must be between 1 and"),
        ({"threads": "2"}, TypeError, "threads must be an integer"),
        ({"retries": -1}, ValueError, "retries must be an integer 0 or more"),
    ],
)
def test_run_batch_bad_threads_leave_no_folder(pair_folder, tmp_path, kwargs, error, message):
    out = tmp_path / "out"
    with pytest.raises(error, match=message):
        run_batch(find_pairs(pair_folder), out, max_disparity=4, method="block", **kwargs)
    assert not out.exists()


def test_run_batch_restores_numbas_thread_count(pair_folder, tmp_path):
    numba = pytest.importorskip("numba")
    if numba.config.NUMBA_NUM_THREADS < 2:
        pytest.skip("needs two numba threads")
    before = numba.get_num_threads()
    report = run_batch(
        find_pairs(pair_folder), tmp_path / "out", max_disparity=4, method="block", threads=1
    )
    assert report.ok
    assert numba.get_num_threads() == before


@pytest.mark.parametrize(
    ("pair", "error", "message"),
    [
        (("a.png", "b.png"), TypeError, "pairs must be Pair objects, got tuple"),
        (Pair(3, None, None), TypeError, "a pair name must be a string, got 3"),
        (Pair("a\0b", None, None), ValueError, r"'a\\x00b' cannot be a file name"),
        (Pair("n" * 239, None, None), ValueError, "longer than 238 bytes"),
    ],
)
def test_run_batch_bad_pairs_leave_no_folder(tmp_path, pair, error, message):
    out = tmp_path / "out"
    with pytest.raises(error, match=message):
        run_batch([pair], out, max_disparity=4, method="block")
    assert not out.exists()


def test_a_pair_without_images_fails_with_a_reason(tmp_path):
    report = run_batch([Pair("lonely", None, None)], tmp_path / "out", max_disparity=4)
    assert [o.message for o in report.failed] == ["pair 'lonely' has no left image"]


def test_pairs_csv_with_a_byte_order_mark(tmp_path):
    path = tmp_path / "pairs.csv"
    path.write_bytes("left,right\nx.png,y.png\n".encode("utf-8-sig"))
    pairs = find_pairs(path)
    assert [(p.name, p.left.name, p.right.name) for p in pairs] == [("x", "x.png", "y.png")]


def test_pairs_csv_with_an_oversized_field(tmp_path):
    path = tmp_path / "pairs.csv"
    path.write_text('x.png,y.png\n"' + "a" * 200_000 + '",b.png\n')
    with pytest.raises(ValueError, match=r"cannot read pairs '.*pairs\.csv': field larger"):
        find_pairs(path)


# --- video ----------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("frames", "kwargs", "error", "message"),
    [
        ([np.full((16, 16), 0.5)], {}, TypeError, "frame 0 must be uint8, got dtype float64"),
        ([np.zeros((16, 16, 4), np.uint8)], {}, ValueError, r"must have shape \(H, W\)"),
        ([np.zeros((0, 16), np.uint8)], {}, ValueError, "frame 0 is empty"),
        ([np.zeros((16, 16), np.uint8)], {"fps": 0}, ValueError, "fps must be a positive"),
        ([np.zeros((16, 16), np.uint8)], {"quality": 11}, ValueError, "quality must be"),
    ],
)
def test_write_video_bad_frames_and_settings(tmp_path, frames, kwargs, error, message):
    from dcstereo.batch.video import write_video

    with pytest.raises(error, match=message):
        write_video(tmp_path / "v.mp4", frames, **kwargs)
    assert _listing(tmp_path) == []


def test_write_video_reports_ffmpeg_failing_and_leaves_nothing(tmp_path):
    from dcstereo.batch.video import write_video

    (tmp_path / "v.xyz").write_bytes(b"old")
    with pytest.raises(ValueError, match=r"cannot write video '.*v\.xyz': Unable to choose"):
        write_video(tmp_path / "v.xyz", [np.zeros((16, 16), np.uint8)] * 2)
    assert _listing(tmp_path) == ["v.xyz"]
    assert (tmp_path / "v.xyz").read_bytes() == b"old"


def test_write_video_quality_zero_as_documented(tmp_path):
    from dcstereo.batch.video import open_sequence, write_video

    path = tmp_path / "v.mp4"
    assert write_video(path, [np.zeros((16, 32), np.uint8)] * 3, quality=0) == 3
    assert open_sequence(path).frame_count == 3


def test_read_video_of_a_missing_file_or_a_folder(tmp_path):
    from dcstereo.batch.video import read_video

    with pytest.raises(ValueError, match=r"cannot read video '.*nope\.mp4': no such file"):
        next(read_video(tmp_path / "nope.mp4"))
    with pytest.raises(ValueError, match="it is a folder"):
        next(read_video(tmp_path))


@pytest.fixture
def frame_folders(tmp_path):
    left, right = _pair()
    for side, image in (("left", left), ("right", right)):
        (tmp_path / side).mkdir()
        io.write_rgb_png(tmp_path / side / "0.png", image)
    return tmp_path / "left", tmp_path / "right"


@pytest.mark.parametrize(
    ("kwargs", "error", "message"),
    [
        ({"threads": 0}, ValueError, "threads must be at least 1"),
        ({"disparity_format": "png", "min_disparity": -2}, ValueError, "not -2..4; use 'pfm'"),
    ],
)
def test_match_sequence_refusals_leave_no_folder(frame_folders, tmp_path, kwargs, error, message):
    from dcstereo.batch.video import match_sequence, open_sequence

    out = tmp_path / "out"
    sequence = open_sequence(*frame_folders)
    with pytest.raises(error, match=message):
        match_sequence(sequence, out, max_disparity=4, method="block", **kwargs)
    assert not out.exists()


def test_match_sequence_needs_a_sequence(tmp_path):
    from dcstereo.batch.video import match_sequence

    with pytest.raises(TypeError, match="sequence must be a StereoSequence"):
        match_sequence([1, 2], tmp_path / "out", max_disparity=4)
    assert not (tmp_path / "out").exists()
