"""Sub-pixel refinement (``dcstereo.refine.subpixel``): the kernel against a plain twin, a known
fractional shift, what it leaves alone, its errors, and ``run --subpixel``."""

from dataclasses import replace

import numpy as np
import pytest

from dcstereo import FLAG_FILLED, io, match
from dcstereo.refine.subpixel import refine_subpixel
from dcstereo.signal import matching_signal
from naive import window_sad
from naive_gcp_bt import window_bt
from test_cli import invoke


def cost(ls, rs, y, x, e, radius, bt=False):
    """Eq. 4 (or BT) at disparity ``e``; inf when no column of the window has both pixels."""
    width = ls.shape[1]
    inside = [
        s for s in range(-radius, radius + 1) if 0 <= x + s < width and 0 <= x - e + s < width
    ]
    window = window_bt if bt else window_sad
    return window(ls, rs, y, x, x - e, radius) if inside else np.inf


def twin(result, left, right, fit):
    """The refinement as its docstring says, cell by cell, with eq. 4's plain twin."""
    ls, rs = matching_signal(left), matching_signal(right)
    p = result.params
    radius, dmin, dmax = p.window // 2, p.min_disparity, p.max_disparity
    d = result.disparity
    out = d.copy()
    for y, x in np.ndindex(d.shape):
        v = float(d[y, x])
        if not np.isfinite(v) or v != int(v) or result.flags[y, x] & FLAG_FILLED:
            continue
        k = int(v)
        if k - 1 < dmin or k + 1 > dmax:
            continue
        bt = p.cost == "bt"
        c0, c1, c2 = (cost(ls, rs, y, x, e, radius, bt) for e in (k - 1, k, k + 1))
        if not (c1 <= c0 and c1 <= c2) or np.inf in (c0, c2):
            continue
        slope = max(c0 - c1, c2 - c1) if fit == "equiangular" else c0 - 2.0 * c1 + c2
        if slope > 0:
            out[y, x] = np.float32(k + (c0 - c2) / (2.0 * slope))
    return out


@pytest.mark.parametrize("cost_name", ["sad", "bt"])
@pytest.mark.parametrize("fit", ["equiangular", "parabola"])
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_kernel_equals_its_twin(fit, seed, cost_name):
    rng = np.random.default_rng(seed)
    h, w = 9, 23
    left = rng.integers(0, 256, (h, w, 3), dtype=np.uint8)
    right = np.roll(left, -3, axis=1)
    right[:, -3:] = rng.integers(0, 256, (h, 3, 3))
    right = np.clip(right.astype(int) + rng.integers(-9, 10, right.shape), 0, 255).astype(np.uint8)
    result = match(
        left, right, max_disparity=6, min_disparity=1, window=3, method="dsi3", cost=cost_name
    )
    # every kind of pixel: random integer disparities, half pixels, none, filled
    d = rng.integers(0, 8, (h, w)).astype(np.float32)
    d[rng.random((h, w)) < 0.1] += 0.5
    d[rng.random((h, w)) < 0.1] = np.nan
    flags = np.where(rng.random((h, w)) < 0.1, FLAG_FILLED, 0).astype(np.uint8)
    result = replace(result, disparity=d, flags=flags)
    refined = refine_subpixel(result, left, right, fit=fit).disparity
    np.testing.assert_array_equal(refined, twin(result, left, right, fit))
    moved = refined != d
    assert moved.sum() > 10  # the case exercises the fit, not only the skips
    assert np.all(np.abs(refined - d)[np.isfinite(d)] <= 0.5)


@pytest.mark.parametrize("cost_name", ["sad", "bt"])
@pytest.mark.parametrize("fit", ["equiangular", "parabola"])
@pytest.mark.parametrize("window, dmin", [(3, 1), (5, -4), (7, 0)])
def test_kernel_equals_its_twin_on_runs_of_one_disparity(fit, window, dmin, cost_name):
    # runs of equal d, broken by skipped pixels and changes: the kernel slides its sums
    # along a run and sums anew after a break; the image edges take the edge rules
    rng = np.random.default_rng(window)
    h, w = 11, 41
    left = rng.integers(0, 256, (h, w), dtype=np.uint8)
    right = np.roll(left, -3, axis=1)
    right = np.clip(right.astype(int) + rng.integers(-20, 21, right.shape), 0, 255)
    right = right.astype(np.uint8)
    kwargs = {"max_disparity": dmin + 9, "min_disparity": dmin, "window": window}
    kwargs["cost"] = cost_name
    result = match(left, right, method="dsi3", **kwargs)
    d = np.repeat(rng.integers(dmin, dmin + 10, (h, 6)), 7, axis=1)[:, :w].astype(np.float32)
    d[:, 1::9] += 0.5  # skipped: a half pixel breaks the run
    d[rng.random((h, w)) < 0.05] = np.nan
    result = replace(result, disparity=d, flags=np.zeros((h, w), np.uint8))
    refined = refine_subpixel(result, left, right, fit=fit).disparity
    np.testing.assert_array_equal(refined, twin(result, left, right, fit))
    assert (refined != d).sum() > 40  # the fits ran, not only the skips


def shifted_pair(true, height=60, width=160, seed=0):
    """A smooth texture and its copy shifted by a fractional ``true`` (linear interpolation)."""
    rng = np.random.default_rng(seed)
    xs = np.arange(width + 40, dtype=float)[None, :]
    ys = np.arange(height, dtype=float)[:, None]
    tex = sum(
        np.sin(rng.uniform(0.05, 0.6) * xs + rng.uniform(0.02, 0.5) * ys + rng.uniform(0, 6.3))
        for _ in range(30)
    )
    tex = (tex - tex.min()) / (tex.max() - tex.min()) * 255
    right = np.stack([np.interp(np.arange(width) + 20 + true, np.arange(width + 40), row)
                      for row in tex])  # fmt: skip
    return np.rint(tex[:, 20 : 20 + width]).astype(np.uint8), np.rint(right).astype(np.uint8)


@pytest.mark.parametrize("true", [4.25, 4.75])
def test_a_fractional_shift_is_recovered(true):
    left, right = shifted_pair(true)
    result = match(left, right, max_disparity=10, method="dsi3")
    inner = np.s_[4:-4, 16:-16]
    integer = np.nanmean(np.abs(result.disparity[inner] - true))
    assert integer == pytest.approx(0.25, abs=0.02)  # the DP rounds to the nearest pixel
    equi = refine_subpixel(result, left, right).disparity[inner]
    para = refine_subpixel(result, left, right, fit="parabola").disparity[inner]
    assert np.nanmean(np.abs(equi - true)) < 0.1
    # the parabola is pulled toward whole pixels: less exact than the lines, better than none
    assert np.nanmean(np.abs(equi - true)) < np.nanmean(np.abs(para - true)) < integer
    assert abs(np.nanmean(equi) - true) < 0.05


def test_what_is_left_alone(pair):
    folder, _ = pair
    left, right = io.read_image(folder / "left.png"), io.read_image(folder / "right.png")
    result = match(left, right, max_disparity=10, fill=True, method="dc")
    refined = refine_subpixel(result, left, right)
    d, r = result.disparity, refined.disparity
    keep = ((result.flags & FLAG_FILLED) != 0) | (d == 0) | (d == 10) | (np.floor(d) != d)
    np.testing.assert_array_equal(r[keep], d[keep])
    assert (r != d).any() and np.all(np.abs(r - d) <= 0.5)
    assert refined.flags is result.flags and refined.params == result.params
    assert np.array_equal(refined.features, result.features)


def test_errors(pair):
    folder, _ = pair
    left, right = io.read_image(folder / "left.png"), io.read_image(folder / "right.png")
    result = match(left, right, max_disparity=10, method="dc")
    with pytest.raises(ValueError, match="fit must be one of equiangular, parabola, got 'cubic'"):
        refine_subpixel(result, left, right, fit="cubic")
    with pytest.raises(TypeError, match="result must be a DisparityResult, got ndarray"):
        refine_subpixel(result.disparity, left, right)
    with pytest.raises(ValueError, match="not the pair matched"):
        refine_subpixel(result, left[:, :-1], right[:, :-1])
    with pytest.raises(ValueError, match="differ in shape"):
        refine_subpixel(result, left, right[:, :-1])


def test_run_subpixel(pair):
    folder, _ = pair
    left, right = io.read_image(folder / "left.png"), io.read_image(folder / "right.png")
    for fit in ("equiangular", "parabola"):
        out = folder / f"d-{fit}.pfm"
        result = invoke("run", folder / "left.png", folder / "right.png", "-o", out,
                        "--max-disparity", 10, "--subpixel", fit, "--method", "dc",
                        "-q")  # fmt: skip
        assert result.exit_code == 0, result.output
        plain = match(left, right, max_disparity=10, method="dc")
        expected = refine_subpixel(plain, left, right, fit=fit)
        np.testing.assert_array_equal(
            io.read_pfm(out), np.nan_to_num(expected.disparity, nan=np.inf)
        )
    result = invoke("run", folder / "left.png", folder / "right.png", "-o", folder / "x.pfm",
                    "--max-disparity", 10, "--subpixel", "cubic")  # fmt: skip
    assert result.exit_code == 2 and "cubic" in result.output


@pytest.mark.parametrize("fit", ["equiangular", "parabola"])
def test_match_refines_before_filling(pair, fit):
    folder, _ = pair
    left, right = io.read_image(folder / "left.png"), io.read_image(folder / "right.png")
    plain = match(left, right, max_disparity=10, method="dc")
    refined = refine_subpixel(plain, left, right, fit=fit)
    inside = match(left, right, max_disparity=10, subpixel=fit, method="dc")
    np.testing.assert_array_equal(inside.disparity, refined.disparity)
    assert inside.params.subpixel == fit and plain.params.subpixel is None
    filled = match(left, right, max_disparity=10, subpixel=fit, fill=True, method="dc")
    np.testing.assert_array_equal(filled.disparity, refined.filled().disparity)
    np.testing.assert_array_equal(filled.flags, refined.filled().flags)
    with pytest.raises(ValueError, match=r"'none' \(off\) or one of equiangular, parabola"):
        match(left, right, max_disparity=10, subpixel="linear")


def test_sgm_fits_its_own_costs_and_refine_refuses_its_results(pair):
    folder, _ = pair
    left, right = io.read_image(folder / "left.png"), io.read_image(folder / "right.png")
    plain = match(left, right, max_disparity=10)
    with pytest.raises(ValueError, match="sgm fits its own aggregated costs"):
        refine_subpixel(plain, left, right, fit="parabola")
    refined = match(left, right, max_disparity=10, subpixel="parabola")
    d = refined.disparity
    assert np.any(d != np.floor(d))  # fractions: the fit through the aggregated costs
    assert np.nanmax(np.abs(d - plain.disparity)) <= 2  # the median may move a pixel's value
