"""Confidence (``dcstereo.refine.confidence``): the kernel against a plain twin, what it says on
known pairs, its errors, and ``run --confidence-out``."""

from dataclasses import replace

import numpy as np
import pytest

import naive
import naive_gcp_bt
from dcstereo import FLAG_FILLED, io, match
from dcstereo.refine.confidence import confidence
from dcstereo.refine.subpixel import refine_subpixel
from dcstereo.signal import matching_signal
from test_cli import invoke


def twin(result, left, right):
    """The confidence as the module says, pixel by pixel, from the plain cost twins."""
    ls, rs = matching_signal(left), matching_signal(right)
    p = result.params
    costs = naive_gcp_bt.row_costs_bt if p.cost == "bt" else naive.row_costs
    radius, dmin, ndisp = p.window // 2, p.min_disparity, p.num_disparities
    d = result.disparity
    out = np.full(d.shape, np.nan, dtype=np.float32)
    for y in range(d.shape[0]):
        row = costs(ls, rs, y, dmin, ndisp, radius)
        for x in range(d.shape[1]):
            v = float(d[y, x])
            if not np.isfinite(v) or result.flags[y, x] & FLAG_FILLED:
                continue
            k = v - dmin
            own = min(row[x, int(np.floor(k))], row[x, int(np.ceil(k))])
            rivals = [row[x, j] for j in range(ndisp) if abs(j - k) >= 2]
            rival = min(rivals, default=np.inf)
            if rival == np.inf:
                continue
            if rival > 0:
                out[y, x] = max((rival - own) / rival, -1.0)
            else:
                out[y, x] = 0.0 if own == 0 else -1.0
    return out


@pytest.mark.parametrize("cost", ["sad", "bt"])
@pytest.mark.parametrize("seed", [0, 1])
def test_kernel_equals_its_twin(cost, seed):
    rng = np.random.default_rng(seed)
    h, w = 8, 21
    left = rng.integers(0, 256, (h, w), dtype=np.uint8)
    right = np.roll(left, -2, axis=1)
    right = np.clip(right.astype(int) + rng.integers(-20, 21, right.shape), 0, 255).astype(np.uint8)
    left[:3, 5:12] = right[:3, 3:10] = 77  # a flat patch: ties
    result = match(left, right, max_disparity=5, min_disparity=-1, window=3, method="dsi3",
                   cost=cost)  # fmt: skip
    # integer, half-pixel and sub-pixel disparities over the whole range, none, filled
    d = rng.integers(-1, 6, (h, w)).astype(np.float32)
    d[(rng.random((h, w)) < 0.15) & (d < 5)] += 0.5
    d[(rng.random((h, w)) < 0.15) & (d < 5) & (d == np.floor(d))] += np.float32(0.25)
    d[(rng.random((h, w)) < 0.1) & (d < 5) & (d == np.floor(d))] += np.float32(0.875)
    d[rng.random((h, w)) < 0.1] = np.nan
    flags = np.where(rng.random((h, w)) < 0.1, FLAG_FILLED, 0).astype(np.uint8)
    result = replace(result, disparity=d, flags=flags)
    got = confidence(result, left, right)
    np.testing.assert_array_equal(got, twin(result, left, right))
    finite = got[np.isfinite(got)]
    assert finite.size > 50 and finite.min() >= -1 and finite.max() <= 1
    assert (finite < 0).any() and (finite > 0).any()  # random disparities: both kinds


def test_what_it_says_on_known_pairs():
    rng = np.random.default_rng(3)
    texture = rng.integers(0, 256, (40, 90), dtype=np.uint8)
    left, right = texture[:, :80], texture[:, 4:84]  # left x is right x - 4: d = 4
    result = match(left, right, max_disparity=8, method="dsi3")
    conf = confidence(result, left, right)
    inner = np.s_[3:-3, 12:-3]
    assert np.all(result.disparity[inner] == 4)
    assert np.nanmin(conf[inner]) > 0.5  # random texture: one disparity fits
    # the same pixels forced three off: the data prefer the truth, so below 0
    wrong = replace(result, disparity=np.where(np.isfinite(result.disparity), 7.0, np.nan)
                    .astype(np.float32))  # fmt: skip
    assert np.nanmax(confidence(wrong, left, right)[inner]) < 0
    # a flat image: every disparity ties
    flat = np.full((20, 40), 128, dtype=np.uint8)
    flat_result = match(flat, flat, max_disparity=8, method="dsi3")
    flat_conf = confidence(flat_result, flat, flat)
    has = np.isfinite(flat_result.disparity)
    assert np.all(flat_conf[has][np.isfinite(flat_conf[has])] == 0)
    # NaN only in the columns where no disparity two or more off has its partner inside
    nan_columns = np.nonzero(np.isnan(flat_conf).any(axis=0) & has.any(axis=0))[0]
    assert np.all(flat_result.disparity == 0) and list(nan_columns) == [0, 1]
    # no estimate, or filled: NaN
    filled = match(left, right, max_disparity=8, method="dsi3", fill=True)
    conf = confidence(filled, left, right)
    assert np.all(np.isnan(conf[(filled.flags & FLAG_FILLED) != 0]))
    assert (filled.flags & FLAG_FILLED).any()
    # a range of two disparities has no rival two pixels away
    tiny = match(left, right, max_disparity=1, method="dsi3")
    assert np.all(np.isnan(confidence(tiny, left, right)))


def test_errors(pair):
    folder, _ = pair
    left, right = io.read_image(folder / "left.png"), io.read_image(folder / "right.png")
    result = match(left, right, max_disparity=10)
    with pytest.raises(TypeError, match="result must be a DisparityResult, got ndarray"):
        confidence(result.disparity, left, right)
    with pytest.raises(ValueError, match="not the pair matched"):
        confidence(result, left[1:], right[1:])


def test_run_confidence_out(pair):
    folder, _ = pair
    left, right = io.read_image(folder / "left.png"), io.read_image(folder / "right.png")
    result = invoke("run", folder / "left.png", folder / "right.png", "-o", folder / "d.pfm",
                    "--max-disparity", 10, "--confidence-out", folder / "c.pfm", "-q")  # fmt: skip
    assert result.exit_code == 0, result.output
    expected = confidence(match(left, right, max_disparity=10), left, right)
    np.testing.assert_array_equal(
        io.read_pfm(folder / "c.pfm"), np.nan_to_num(expected, nan=np.inf)
    )
    # after --subpixel: the confidence of the refined map
    result = invoke("run", folder / "left.png", folder / "right.png", "-o", folder / "d2.pfm",
                    "--max-disparity", 10, "--subpixel", "equiangular", "--confidence-out",
                    folder / "c2.pfm", "--method", "dc", "-q")  # fmt: skip
    assert result.exit_code == 0, result.output
    refined = refine_subpixel(match(left, right, max_disparity=10, method="dc"), left, right)
    np.testing.assert_array_equal(
        io.read_pfm(folder / "c2.pfm"), np.nan_to_num(confidence(refined, left, right), nan=np.inf)
    )
    result = invoke("run", folder / "left.png", folder / "right.png", "-o", folder / "d3.pfm",
                    "--max-disparity", 10, "--confidence-out", folder / "c.png")  # fmt: skip
    assert result.exit_code == 1
    assert "cannot write --confidence-out" in result.output and "use .pfm" in result.output
    assert not (folder / "d3.pfm").exists()


def test_an_opencv_result_is_rated_with_the_sad(pair):
    pytest.importorskip("cv2")
    from dcstereo.compat.opencv import match_opencv

    folder, _ = pair
    left, right = io.read_image(folder / "left.png"), io.read_image(folder / "right.png")
    result = match_opencv(left, right, max_disparity=10, window=5)
    got = confidence(result, left, right)
    # its disparities are sixteenths: rated between the whole pixels around them
    np.testing.assert_array_equal(got, twin_sad(result, left, right))
    assert np.isfinite(got).sum() > 100


def twin_sad(result, left, right):
    """The twin with the SAD and the range asked for (OpenCV's params have no cost)."""
    from dcstereo.params import MatchParams

    p = result.params
    params = MatchParams(max_disparity=p.max_disparity, min_disparity=p.min_disparity,
                         window=p.window)  # fmt: skip
    return twin(replace(result, params=params), left, right)


def test_run_ply_min_confidence(pair):
    from dcstereo.geometry import Calibration, point_cloud
    from test_geometry import read_ply

    folder, _ = pair
    left, right = io.read_image(folder / "left.png"), io.read_image(folder / "right.png")
    args = ["run", folder / "left.png", folder / "right.png", "-o", folder / "d.pfm",
            "--max-disparity", 10, "--fill", "--focal", 300, "--baseline", 80]  # fmt: skip
    result = invoke(*args, "--ply", folder / "sure.ply", "--ply-min-confidence", 0.3)
    assert result.exit_code == 0, result.output
    matched = match(left, right, max_disparity=10, fill=True)
    sure = confidence(matched, left, right)
    keep = sure >= 0.3  # NaN (filled, none) is never kept
    assert 0 < keep.sum() < np.isfinite(matched.disparity).sum()
    expected = point_cloud(matched.disparity, Calibration(300, 80, 31.5, 11.5), left, mask=keep)
    _, vertices = read_ply(folder / "sure.ply")
    np.testing.assert_array_equal(np.stack([vertices[a] for a in "xyz"], 1), expected.points)
    # the last line (the first may be the notice that the kernels compile)
    assert result.output.splitlines()[-1] == f"{len(expected)} points -> {folder / 'sure.ply'}"
    for extra, message in (
        (["--ply-min-confidence", 0.3], "--ply-min-confidence is used only with --ply"),
        (["--ply", folder / "x.ply", "--ply-min-confidence", 2],
         "--ply-min-confidence must be between -1 and 1, got 2"),
    ):  # fmt: skip
        result = invoke(*args, *extra)
        assert result.exit_code == 1 and message in result.output, result.output


def test_sgm_confidence_is_the_margin_of_its_aggregated_costs(pair):
    # the twin: the totals of the naive aggregation, the margin over the least rival two or
    # more disparities away, NaN where filled
    import naive_sgm
    from dcstereo.methods import sgm
    from dcstereo.signal import padded_signal

    folder, _ = pair
    left, right = io.read_image(folder / "left.png"), io.read_image(folder / "right.png")
    left, right = left[:10, :40], right[:10, :40]
    result = match(left, right, max_disparity=6)
    sure = confidence(result, left, right)
    params = result.params
    codes = [naive_sgm.census(padded_signal(v, 0), 5, 5) for v in (left, right)]
    colours = sgm.colour_channels(left, right)
    costs = naive_sgm.box_mean(
        naive_sgm.pixel_costs(*codes, *colours, 0, 7, sgm.census_bit_cost((5, 5)), 20), 3
    )
    table = sgm.UNITS * sgm.p2_table(params)
    sums = naive_sgm.aggregate(costs, padded_signal(left, 0), sgm.UNITS * params.p1, table, 8)
    filled = (result.flags & FLAG_FILLED) != 0
    for y, x in zip(*np.nonzero(~filled), strict=True):
        k = int(np.argmin(sums[y, x]))
        rivals = [sums[y, x, j] for j in range(7) if abs(j - k) >= 2]
        rival = min(rivals)
        expected = np.float32((rival - sums[y, x, k]) / rival)
        assert sure[y, x] == expected, (y, x)
    assert np.isnan(sure[filled]).all()
    assert np.nanmin(sure) >= 0 and np.nanmax(sure) <= 1
