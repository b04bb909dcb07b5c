"""The colour-weighted median (``refine.weighted_median``): its kernel, its tables, its use."""

import numpy as np
import pytest

import dcstereo
import naive_weighted_median as naive
from dcstereo.params import MatchParams
from dcstereo.refine import _weighted_median as kernels
from dcstereo.refine import weighted_median as wm
from dcstereo.refine._median import merge_network, sort_network, window_plan
from dcstereo.result import FLAG_FEATURE, FLAG_OCCLUDED, DisparityResult
from pins import kitti_d1, middlebury_bad1


def test_weight_tables_equal_their_definition():
    colour, space = wm.weight_tables(4, 20.0, 3.0)
    twin_colour, twin_space = naive.weights(4, 20.0, 3.0)
    assert colour.dtype == space.dtype == np.int64
    assert colour.tolist() == twin_colour and space.tolist() == twin_space
    assert colour[0] == space[4, 4] == wm.UNIT  # the centre pixel weighs UNIT * UNIT


def test_weighted_median_by_hand():
    # one row [1, 5, 2], the guide [0, 0, 200], radius 1 (colour 20, space 3): weights
    # 1024 * 1024 = 1048576 for the pixel itself, 1024 * 734 = 751616 for a neighbour of the
    # same colour, 0 across the edge (round(1024 * exp(-10)) = 0). Pixel 1 sees 1 (751616),
    # 5 (1048576) and 2 (0): half of 1800192 is reached at 5, so it keeps 5 where the plain
    # median would give 2; pixel 0 sees 1 (1048576) and 5 (751616): 1; pixel 2 sees 5 (0)
    # and 2: 2. The edge stays.
    d = np.array([[1.0, 5.0, 2.0]], dtype=np.float32)
    guide = np.array([[[0, 0, 200]]], dtype=np.int16)
    colour, space = wm.weight_tables(1, 20.0, 3.0)
    assert space[1, 0] == 734 and colour[200] == 0
    out = wm.weighted_medians(d, guide, np.ones_like(d, bool), 1, colour, space)
    assert out.tolist() == [[1.0, 5.0, 2.0]]
    # without the edge in the guide: pixel 1 sees 1 and 2 (751616 each) and 5 (1048576):
    # the running weight reaches half at 2
    flat = np.zeros_like(guide)
    out = wm.weighted_medians(d, flat, np.ones_like(d, bool), 1, colour, space)
    assert out[0, 1] == 2.0


@pytest.mark.parametrize("seed", range(6))
def test_kernel_equals_its_twin(seed):
    rng = np.random.default_rng(seed)
    # wider than a chunk of the kernel for some seeds: chunks and the image's edges
    height = int(rng.integers(3, 14))
    width = int(rng.integers(3, 14)) if seed < 3 else kernels.CHUNK + int(rng.integers(1, 40))
    channels = 1 if seed % 2 else 3
    # few distinct values, so that ties and equal running weights occur; negatives, zeros
    d = (rng.integers(-4, 6, (height, width)) / 2).astype(np.float32)
    d[rng.random((height, width)) < 0.15] = np.nan
    d[rng.random((height, width)) < 0.03] = np.inf
    guide = rng.integers(0, 256, (channels, height, width)).astype(np.int16)
    guide[:, : height // 2] //= 16  # a region of nearly one colour
    moved = np.isfinite(d) & (rng.random((height, width)) < 0.9)
    radius = 1 + seed % 4
    colour, space = wm.weight_tables(radius, 15.0 + seed, 2.0 + seed)
    out = wm.weighted_medians(d, guide, moved, radius, colour, space)
    twin = naive.weighted_median_rows(d, guide, moved, radius, 15.0 + seed, 2.0 + seed)
    assert out.tobytes() == twin.tobytes()


def _tall_case(seed, height):
    rng = np.random.default_rng(seed)
    d = rng.integers(-4, 6, (height, 19)) / 2 + rng.integers(0, 2, (height, 19)) / 8
    d = d.astype(np.float32)
    d[rng.random(d.shape) < 0.15] = np.nan
    guide = rng.integers(0, 256, (3, height, 19)).astype(np.int16)
    guide[:, height // 3 :] //= 8
    return d, guide, np.isfinite(d) & (rng.random(d.shape) < 0.9)


@pytest.mark.parametrize("radius", [2, 4])
def test_kernel_equals_its_twin_across_bands(radius):
    # three bands of rows: past the first, a band's rows take the weights of the rows
    # above from its own ring, which starts by computing the radius rows above it again
    d, guide, moved = _tall_case(radius, 2 * kernels.BAND + 5)
    colour, space = wm.weight_tables(radius)
    out = wm.weighted_medians(d, guide, moved, radius, colour, space)
    twin = naive.weighted_median_rows(d, guide, moved, radius, wm.COLOUR_SCALE, wm.SPACE_SCALE)
    assert out.tobytes() == twin.tobytes()


def test_the_same_at_any_thread_count(monkeypatch):
    # bands go to whichever thread is free: one task, a few, more than bands (the counts
    # the kernel is given, whatever the machine's cores)
    d, guide, moved = _tall_case(9, 3 * kernels.BAND + 2)
    colour, space = wm.weight_tables()
    outs = []
    for threads in (1, 3, 64):
        monkeypatch.setattr(wm.nb, "get_num_threads", lambda t=threads: t)
        outs.append(wm.weighted_medians(d, guide, moved, wm.RADIUS, colour, space))
    for out in outs[1:]:
        assert out.tobytes() == outs[0].tobytes()


def test_forward_weights_by_hand():
    # row 0 of a 2 x 2 image, radius 1: the weights of the forward offsets (0, 1), (1, -1),
    # (1, 0), (1, 1) (the others come from the samples' rows); outside ones left as they are
    guide = np.array([[10, 30], [50, 13]], dtype=np.int16)[None].repeat(3, axis=0)
    colour, space = wm.weight_tables(1)  # space: 1024 centre, 734 beside, 639 corners
    slot = np.full((4, 2), -1, dtype=np.int32)
    diff = np.empty(2, dtype=np.int32)
    kernels.forward_weights(guide, 0, 1, colour.astype(np.int32), space.astype(np.int32),
                            diff, slot)  # fmt: skip
    # pixel (0, 0) = 10: (0, 1) is 30 (g 20), (1, 0) 50 (g 40), (1, 1) 13 (g 3)
    assert slot[:, 0].tolist() == [734 * colour[20], -1, 734 * colour[40], 639 * colour[3]]
    # pixel (0, 1) = 30: (1, -1) is 50 (g 20), (1, 0) 13 (g 17); (0, 1), (1, 1) outside
    assert slot[:, 1].tolist() == [-1, 639 * colour[20], 734 * colour[17], -1]


@pytest.mark.parametrize("seed", range(2))
def test_kernel_sums_large_weights_in_64_bits(seed):
    # weights near 2**30 each: a window's total is past int32, which the wrapper sees from
    # the tables (int32 sums would wrap, and the medians with them)
    rng = np.random.default_rng(seed)
    d = (rng.integers(-4, 6, (7, 30)) / 2).astype(np.float32)
    d[rng.random(d.shape) < 0.1] = np.nan
    guide = rng.integers(0, 256, (3, 7, 30)).astype(np.int16)
    moved = np.isfinite(d)
    radius = 1 + seed
    colour = rng.integers(1, 2**15, 256).astype(np.int64)
    space = rng.integers(2**14, 2**15, (2 * radius + 1,) * 2).astype(np.int64)
    space = np.maximum(space, space[::-1, ::-1])  # symmetric about the centre, as a distance's
    assert 2 * colour.max() * space.max() * (2 * radius + 1) ** 2 >= 2**31
    out = wm.weighted_medians(d, guide, moved, radius, colour, space)
    twin = naive.weighted_median_rows(d, guide, moved, radius, 0, 0,
                                      tables=(colour.tolist(), space.tolist()))  # fmt: skip
    assert out.tobytes() == twin.tobytes()


def test_kernel_refuses_a_distance_table_not_symmetric():
    # the kernel takes a pixel's weight of its sample at -o from the sample's of it at o
    d = np.zeros((3, 4), np.float32)
    colour, space = wm.weight_tables(1)
    space[0, 1] += 1
    with pytest.raises(ValueError, match="symmetric"):
        wm.weighted_medians(d, np.zeros((1, 3, 4), np.int16), np.isfinite(d), 1, colour, space)


def test_sortable_keys_order_as_the_floats():
    values = np.array([-np.inf, -3e9, -2.5, -1e-30, -0.0, 0.0, 1e-30, 0.25, 7.0, 3e9],
                      dtype=np.float32)  # fmt: skip
    keys = [kernels.sample_key(b) for b in values[1:-1].view(np.int32)]
    assert keys == sorted(keys) and keys[3] == keys[4] == 0  # -0.0 and +0.0 alike
    assert len(set(keys)) == len(keys) - 1
    ends = [kernels.sample_key(b) for b in np.float32([-np.inf, np.inf, np.nan]).view(np.int32)]
    assert ends == [kernels.EMPTY] * 3 and max(keys) < kernels.EMPTY  # no estimate: last


@pytest.mark.parametrize("count", [2, 9, 25, 49, 81])
def test_sort_network_sorts(count):
    network = sort_network(count)
    rng = np.random.default_rng(count)
    for _ in range(50):
        values = rng.integers(0, 5, count).tolist()
        for i, j in network:
            values[i], values[j] = min(values[i], values[j]), max(values[i], values[j])
        assert values == sorted(values)
    assert len(sort_network(81)) == 864


@pytest.mark.parametrize(
    ("m", "n"), [(1, 1), (1, 2), (2, 1), (9, 9), (18, 18), (36, 9), (36, 45), (7, 3)]
)
def test_merge_network_merges_every_pair_of_sorted_lists(m, n):
    # the 0-1 principle for merging: a network that merges every pair of sorted lists of
    # zeros and ones merges every pair of sorted lists
    exchanges, order = merge_network(m, n)
    assert sorted(order.tolist()) == list(range(m + n))
    for ones_a in range(m + 1):
        for ones_b in range(n + 1):
            values = [0] * (m - ones_a) + [1] * ones_a + [0] * (n - ones_b) + [1] * ones_b
            for i, j in exchanges:
                values[i], values[j] = min(values[i], values[j]), max(values[i], values[j])
            merged = [values[k] for k in order]
            assert merged == sorted(merged), (ones_a, ones_b)


def test_merge_network_by_hand():
    # one value (row 0) and two sorted (rows 1, 2): Batcher's merge of 2 + 2 wires (0, 2),
    # (1, 3), (1, 2), the first list's padding on wire 1, the second's on wire 3. (0, 2):
    # rows 0 and 1. (1, 3): the padding and the second list's last value (row 2), which
    # moves to wire 1: no exchange, the order records it. (1, 2): wire 1 (row 2) and wire 2
    # (row 1), min to row 2. The merged list: wires 0, 1, 2, that is rows 0, 2, 1.
    exchanges, order = merge_network(1, 2)
    assert exchanges.tolist() == [[0, 1], [2, 1]]
    assert order.tolist() == [0, 2, 1]
    # 5 | 1 7: 1 goes to row 0 and 5 to row 1; then 5 to row 2 and 7 to row 1
    values = [5, 1, 7]
    for i, j in exchanges:
        values[i], values[j] = min(values[i], values[j]), max(values[i], values[j])
    assert values == [1, 7, 5] and [values[k] for k in order] == [1, 5, 7]


def plan_windows(keys, side, chunk):
    """``window_plan(side)`` run in numpy on a row of columns: ``(side**2, chunk)`` sorted."""
    steps, exchanges, orders, columns = window_plan(side)
    tree = np.zeros((orders.max() + 1, keys.shape[1]), dtype=keys.dtype)
    tree[:side] = keys

    def exchange(rows, lanes):
        for i, j in rows:
            low, high = tree[i, :lanes].copy(), tree[j, :lanes].copy()
            tree[i, :lanes], tree[j, :lanes] = np.minimum(low, high), np.maximum(low, high)

    exchange(columns, keys.shape[1])
    for a_order, a_rows, a_shift, b_order, b_rows, b_shift, start, _, first, last, lanes in steps:
        n = chunk + lanes
        for k in range(a_rows):
            tree[start + k, :n] = tree[orders[a_order + k], a_shift : a_shift + n]
        for k in range(b_rows):
            tree[start + a_rows + k, :n] = tree[orders[b_order + k], b_shift : b_shift + n]
        exchange(exchanges[first:last], n)
    return tree[orders[steps[-1, 7] : steps[-1, 7] + side * side], :chunk]


@pytest.mark.parametrize("side", [3, 5, 7, 9, 11])
def test_window_plan_sorts_every_window_of_a_row(side):
    # the columns of a row of windows (a lane a column), the plan's merges: each window's
    # values sorted, against numpy's sort of the window
    rng = np.random.default_rng(side)
    chunk = 12
    for _ in range(5):
        keys = rng.integers(0, 7, (side, chunk + side - 1))
        got = plan_windows(keys, side, chunk)
        for lane in range(chunk):
            assert got[:, lane].tolist() == sorted(keys[:, lane : lane + side].ravel().tolist())


def test_window_plan_merges_fewer_than_the_window_sort():
    steps, exchanges, orders, columns = window_plan(9)
    assert len(exchanges) + len(columns) == 439 + 28 < len(sort_network(81)) == 864
    assert orders.max() + 1 == 9 + 18 + 36 + 45 + 81  # the buffer's rows


def test_filter_keeps_features_holes_and_flags():
    params = MatchParams(max_disparity=8, method="sgm", fill=False)
    d = np.full((5, 12), 4.0, dtype=np.float32)
    d[2, 6] = 7.0  # a spike in a region of one colour goes
    d[1, 9] = 7.5  # a feature pair keeps its value
    d[3, 3] = np.nan  # no estimate: stays without
    flags = np.zeros(d.shape, np.uint8)
    flags[1, 9] = FLAG_FEATURE
    flags[3, 3] = FLAG_OCCLUDED
    result = DisparityResult(d, flags, params, np.full(5, np.nan))
    left = np.full((5, 12), 90, np.uint8)
    out = wm.weighted_median_filter(result, left)
    assert out.disparity[2, 6] == 4.0 and out.disparity[1, 9] == 7.5
    assert np.isnan(out.disparity[3, 3]) and (out.flags == flags).all()


def test_filter_refuses_bad_arguments():
    result = dcstereo.match(np.zeros((8, 20), np.uint8), np.zeros((8, 20), np.uint8),
                            max_disparity=4)  # fmt: skip
    with pytest.raises(TypeError, match="DisparityResult"):
        wm.weighted_median_filter(result.disparity, np.zeros((8, 20), np.uint8))
    with pytest.raises(ValueError, match="radius"):
        wm.weighted_median_filter(result, np.zeros((8, 20), np.uint8), radius=0)
    with pytest.raises(ValueError, match="colour_scale"):
        wm.weighted_median_filter(result, np.zeros((8, 20), np.uint8), colour_scale=0.0)
    with pytest.raises(ValueError, match="shape"):
        wm.weighted_median_filter(result, np.zeros((8, 21), np.uint8))


def test_match_runs_it_as_its_median_stage():
    # median="weighted": match's median stage is weighted_median_filter on the map that
    # median=0 gives (sgm: filled by its core; the filter then leaves nothing to fill)
    rng = np.random.default_rng(3)
    right = rng.integers(0, 256, (40, 70, 3), dtype=np.uint8)
    left = np.roll(right, 4, axis=1)
    left[:, 30:45] = right[:, 28:43]  # a nearer band: a depth edge
    got = dcstereo.match(left, right, max_disparity=10, median="weighted")
    assert got.params.median == "weighted"
    plain = dcstereo.match(left, right, max_disparity=10, median=0)
    expected = wm.weighted_median_filter(plain, left)
    assert got.disparity.tobytes() == expected.disparity.tobytes()
    assert (got.flags == expected.flags).all()
    # a method of the paper: its refinement's median stage, before its fill
    got = dcstereo.match(left, right, max_disparity=10, method="dsi5", median="weighted")
    plain = dcstereo.match(left, right, max_disparity=10, method="dsi5")
    expected = wm.weighted_median_filter(plain, left)
    assert got.disparity.tobytes() == expected.disparity.tobytes()


def test_tiled_match_equals_the_whole_with_the_weighted_median():
    from dcstereo.batch.tiling import match_tiled

    rng = np.random.default_rng(5)
    right = rng.integers(0, 256, (45, 60), dtype=np.uint8)
    left = np.roll(right, 3, axis=1)
    kwargs = dict(max_disparity=8, method="dsi5", median="weighted", fill=True)
    whole = dcstereo.match(left, right, **kwargs)
    tiled = match_tiled(left, right, tile_rows=7, **kwargs)
    assert tiled.disparity.tobytes() == whole.disparity.tobytes()


def test_median_option_takes_weighted_and_refuses_other_text():
    from dcstereo.refine.postfilter import median_filter

    assert MatchParams(max_disparity=4, median="weighted").median == "weighted"
    with pytest.raises(
        TypeError,
        match="median must be an integer, 'weighted' or 'weighted-planes', got 'Weighted'",
    ):
        MatchParams(max_disparity=4, median="Weighted")
    result = dcstereo.match(np.zeros((8, 20), np.uint8), np.zeros((8, 20), np.uint8),
                            max_disparity=4)  # fmt: skip
    with pytest.raises(ValueError, match="weighted_median_filter"):
        median_filter(result, "weighted")


def test_cli_median_weighted(tmp_path):
    from click.testing import CliRunner
    from PIL import Image

    from dcstereo import io
    from dcstereo.cli import main

    rng = np.random.default_rng(2)
    right = rng.integers(0, 256, (30, 50), dtype=np.uint8)
    left = np.roll(right, 3, axis=1)
    Image.fromarray(left).save(tmp_path / "l.png")
    Image.fromarray(right).save(tmp_path / "r.png")
    out = tmp_path / "d.pfm"
    runner = CliRunner()
    args = ["run", str(tmp_path / "l.png"), str(tmp_path / "r.png"), "--max-disparity", "8"]
    result = runner.invoke(main, [*args, "-o", str(out), "--median", "weighted", "-q"])
    assert result.exit_code == 0, result.output
    expected = dcstereo.match(left, right, max_disparity=8, median="weighted")
    assert io.read_pfm(out).tobytes() == expected.disparity.tobytes()
    bad = tmp_path / "bad.pfm"
    result = runner.invoke(main, [*args, "-o", str(bad), "--median", "mean"])
    assert result.exit_code != 0 and "neither an integer nor 'weighted'" in result.output
    assert not bad.exists()


@pytest.mark.slow
@pytest.mark.dataset
@pytest.mark.parametrize(
    ("name", "options", "pinned"),
    [
        # the plain median (5 x 5): teddy 5.803, tsukuba 3.717, Lampshade1 4.015
        ("teddy", {}, 5.629),
        ("tsukuba", {}, 3.362),
        ("Lampshade1", {}, 3.438),
        # with photometric + planes and the plain median: teddy 4.82, tsukuba 3.45
        ("teddy", {"photometric": "matched", "planes": True}, 4.645),
        ("tsukuba", {"photometric": "matched", "planes": True}, 2.992),
    ],
)
def test_weighted_median_keeps_its_measured_accuracy(middlebury_root, name, options, pinned):
    bad = middlebury_bad1(middlebury_root, name, median="weighted", **options)
    assert bad <= pinned + 0.01, f"{name}: bad-1.0 {bad:.3f} % > {pinned}"


@pytest.mark.slow
@pytest.mark.dataset
def test_weighted_median_keeps_its_measured_d1_outdoors():
    d1 = kitti_d1("kitti2012_000030_10", photometric="matched", planes=True, median="weighted")
    assert d1 <= 3.284 + 0.01, f"D1 {d1:.3f} % > 3.284 (3.449 with the plain median)"


def test_batch_records_and_runs_the_weighted_median(tmp_path):
    # a folder of pairs matched with --median weighted: the outputs equal match's, and the
    # option is recorded (a second run with the plain median is refused by name)
    import json

    from click.testing import CliRunner
    from PIL import Image

    from dcstereo import io
    from dcstereo.batch.folders import find_pairs, output_path, run_batch
    from dcstereo.cli import main

    rng = np.random.default_rng(8)
    pairs_dir = tmp_path / "pairs"
    pairs_dir.mkdir()
    for k in range(2):  # one folder a pair, left.png and right.png
        right = rng.integers(0, 256, (24, 40, 3), dtype=np.uint8)
        (pairs_dir / f"pair{k}").mkdir()
        Image.fromarray(np.roll(right, 2 + k, axis=1)).save(pairs_dir / f"pair{k}" / "left.png")
        Image.fromarray(right).save(pairs_dir / f"pair{k}" / "right.png")
    out = tmp_path / "out"
    args = ["batch", str(pairs_dir), "-o", str(out), "--max-disparity", "6"]
    result = CliRunner().invoke(main, [*args, "--median", "weighted", "-q"])
    assert result.exit_code == 0, result.output
    assert json.loads((out / "batch.json").read_text())["median"] == "weighted"
    for pair in find_pairs(pairs_dir):
        expected = dcstereo.match(io.read_image(pair.left), io.read_image(pair.right),
                                  max_disparity=6, median="weighted")  # fmt: skip
        np.testing.assert_array_equal(
            io.read_pfm(output_path(out, pair)), np.nan_to_num(expected.disparity, nan=np.inf)
        )
    with pytest.raises(ValueError, match="median"):
        run_batch(find_pairs(pairs_dir), out, max_disparity=6, median=5)
