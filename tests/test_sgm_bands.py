"""The vertical passes split into bands of lines against the fused passes, bit for bit."""

import numpy as np
import pytest

import dcstereo
import naive_sgm
from dcstereo.aggregate import sgm as sgm_kernels
from dcstereo.evaluation.datasets import load_scene

LANES = 16

#: (height, width): one pixel, one row, one column, widths below the band counts, squares.
SHAPES = [(1, 1), (1, 9), (7, 1), (5, 3), (6, 7), (9, 40), (33, 12)]


def _volume(rng, height, width, lanes, high):
    cost = rng.integers(0, high, height * width * lanes).astype(np.int16)
    luma = rng.integers(0, 4081, (height, width)).astype(np.int32)
    table = rng.integers(20, 400, 4081).astype(np.int64)
    return cost, luma, table


def _fused(cost, luma, table, diagonals, p1=30):
    down, up = np.empty_like(cost), np.empty_like(cost)
    sgm_kernels.vertical_passes(cost, luma, p1, table, diagonals, down, up, 2)
    return down, up


def _split(cost, luma, table, diagonals, threads, bands, p1=30):
    down, up = np.full_like(cost, -7), np.full_like(cost, -7)  # every value written
    sgm_kernels.split_passes(cost, luma, p1, table, diagonals, down, up, threads, bands)
    return down, up


def test_band_edges_by_hand():
    # 3 x 4: lines x - t from -2 to 3 hold 1, 2, 3, 3, 2, 1 pixels; lines x + t from 0 to
    # 5 the same; bands start on the first line past 4 and 8 of the 12 pixels
    np.testing.assert_array_equal(sgm_kernels.band_edges(3, 4, -1, 3), [-2, 1, 2, 4])
    np.testing.assert_array_equal(sgm_kernels.band_edges(3, 4, 1, 3), [0, 3, 4, 6])
    np.testing.assert_array_equal(sgm_kernels.band_edges(3, 4, 0, 3), [0, 2, 3, 4])
    # more bands than lines: some bands empty
    np.testing.assert_array_equal(sgm_kernels.band_edges(2, 1, 0, 3), [0, 1, 1, 1])
    np.testing.assert_array_equal(sgm_kernels.band_edges(1, 2, -1, 4), [0, 1, 1, 2, 2])


@pytest.mark.parametrize(
    ("step", "expected"),
    [
        (1, [[0, 1, 2, 2], [0, 0, 1, 2], [0, 0, 0, 1]]),  # from above: t = y
        (-1, [[0, 0, 0, 1], [0, 0, 1, 2], [0, 1, 2, 2]]),  # from below: t = 2 - y
    ],
)
def test_band_pass_covers_its_parallelogram_by_hand(step, expected):
    # the bands of lines x - t of a 3 x 4 image, edges -2, 1, 2, 4: each writes its pixels
    edges = [-2, 1, 2, 4]
    cost = np.zeros(3 * 4 * LANES, dtype=np.int16)
    luma = np.zeros((3, 4), dtype=np.int32)
    table = np.full(4081, 50, dtype=np.int64)
    band = np.full((3, 4), -1)
    for i in range(3):
        sums = np.full_like(cost, -1)
        y_first = 0 if step == 1 else 2
        sgm_kernels.band_pass(
            cost, luma, y_first, step, -1, edges[i], edges[i + 1], 30, table, False, sums
        )
        written = (sums.reshape(3, 4, LANES) != -1).all(axis=2)
        assert not (written & (band >= 0)).any()  # no pixel in two bands
        band[written] = i
    np.testing.assert_array_equal(band, expected)


@pytest.mark.parametrize("threads", [3, 4, 8, 16])
@pytest.mark.parametrize("diagonals", [True, False])
def test_split_passes_equal_fused_passes(threads, diagonals):
    rng = np.random.default_rng(threads + 100 * diagonals)
    for height, width in SHAPES:
        for lanes in (LANES, 3 * LANES):
            # costs to 12000: the sums of three paths saturate at the int16 bound
            cost, luma, table = _volume(rng, height, width, lanes, 12000)
            down, up = _fused(cost, luma, table, diagonals)
            for bands in {sgm_kernels.split_bands(width, threads), 2 * threads, 1, 3}:
                split_down, split_up = _split(cost, luma, table, diagonals, threads, bands)
                where = f"{height}x{width}x{lanes}, {bands} bands"
                np.testing.assert_array_equal(split_down, down, err_msg=where)
                np.testing.assert_array_equal(split_up, up, err_msg=where)


@pytest.mark.parametrize("paths", [8, 4])
def test_split_passes_equal_twin(paths):
    rng = np.random.default_rng(paths)
    p1 = 30
    for height, width in SHAPES:
        cost, luma, table = _volume(rng, height, width, LANES, 600)
        down, up = _split(cost, luma, table, paths == 8, 8, 5, p1)
        costs = cost.reshape(height, width, LANES).astype(np.int64)
        for sums, dy in ((down, 1), (up, -1)):
            directions = [(0, dy)] + ([(1, dy), (-1, dy)] if paths == 8 else [])
            expected = sum(naive_sgm.path_values(costs, luma, d, p1, table) for d in directions)
            np.testing.assert_array_equal(sums.reshape(height, width, LANES), expected)


def test_split_bands_keep_bands_wide():
    assert sgm_kernels.split_bands(450, 16) == 32  # two a thread
    assert sgm_kernels.split_bands(100, 16) == 100 // sgm_kernels.MIN_BAND
    assert sgm_kernels.split_bands(3, 16) == 1


def _scene_or_pair(middlebury_folder):
    if (middlebury_folder / "teddy").is_dir():
        scene = load_scene(middlebury_folder / "teddy")
        return scene.left, scene.right, scene.max_disparity
    rng = np.random.default_rng(11)
    left = rng.integers(0, 256, (90, 120, 3), dtype=np.uint8)
    return left, np.roll(left, -5, axis=1), 24


@pytest.mark.parametrize("paths", [8, 4])
def test_match_with_split_passes_equals_default(monkeypatch, paths):
    from dcstereo.evaluation.datasets import default_data_dir

    left, right, max_disparity = _scene_or_pair(default_data_dir() / "middlebury")
    monkeypatch.setattr(sgm_kernels, "SPLIT_THREADS", 1 << 20)  # the fused passes
    default = dcstereo.match(left, right, max_disparity=max_disparity, paths=paths)
    monkeypatch.setattr(sgm_kernels, "SPLIT_THREADS", 1)  # the split passes at any count
    calls = []
    split_passes = sgm_kernels.split_passes
    monkeypatch.setattr(
        sgm_kernels, "split_passes", lambda *args: calls.append(1) or split_passes(*args)
    )
    split = dcstereo.match(left, right, max_disparity=max_disparity, paths=paths)
    assert calls  # the split passes ran
    np.testing.assert_array_equal(split.disparity, default.disparity)
    np.testing.assert_array_equal(split.flags, default.flags)


def test_split_passes_run_as_plain_python(tmp_path):
    # NUMBA_DISABLE_JIT=1: the band kernels run as Python (coverage sees them), and give
    # the compiled fused volumes
    import os
    import subprocess
    import sys

    rng = np.random.default_rng(3)
    cost, luma, table = _volume(rng, 5, 7, LANES, 12000)
    down, up = _fused(cost, luma, table, True)
    np.savez(tmp_path / "volume.npz", cost=cost, luma=luma, table=table)
    code = (
        "import numpy as np\n"
        "from dcstereo.aggregate import sgm\n"
        f"v = np.load({str(tmp_path / 'volume.npz')!r})\n"
        "down, up = np.empty_like(v['cost']), np.empty_like(v['cost'])\n"
        "sgm.split_passes(v['cost'], v['luma'], 30, v['table'], True, down, up, 4, 3)\n"
        f"np.savez({str(tmp_path / 'plain.npz')!r}, down=down, up=up)\n"
    )
    env = dict(os.environ, NUMBA_DISABLE_JIT="1")
    done = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    plain = np.load(tmp_path / "plain.npz")
    np.testing.assert_array_equal(plain["down"], down)
    np.testing.assert_array_equal(plain["up"], up)
