"""The band kernels (``BAND_ROWS`` scanlines in lockstep) against the per-row kernels.

Equality is bitwise: disparity, flags and per-row total, with and without anchors.
"""

import os
import subprocess
import sys
import textwrap
from unittest import mock

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import dcstereo
import naive
from dcstereo import _records as records
from dcstereo._vector import scratch, simd
from dcstereo.costs import band as band_costs
from dcstereo.costs import window as costs
from dcstereo.divide import band_match, bands, divide_bands, features, gcp
from dcstereo.evaluation.datasets import load_middlebury
from dcstereo.methods import _bands as mbands
from dcstereo.methods import dc as mdc
from dcstereo.params import MAX_BT_WINDOW, MAX_WINDOW
from dcstereo.scanline import (
    band_dp,  # noqa: F401 (test_band_kernels_run_as_plain_python sets its _PINS_IN_LOOP)
    dp,
    rows,
)
from dcstereo.signal import matching_signal
from test_simd import ssd_in_form


def padded(signal, radius):
    return np.pad(signal, ((radius, radius), (radius, radius)), mode="edge")


def outputs(height, width):
    return (
        np.empty((height, width), dtype=np.float32),
        np.empty((height, width), dtype=np.uint8),
        np.empty(height, dtype=np.float64),
    )


def maps(out):
    """The ``(disparity, flags, total)`` of a driver's ``records.Outputs``."""
    return out.disparity, out.flags, out.total


def per_row(left, right, dmin, ndisp, radius, occ2, five, slant2, bt=False):
    """``match_dsi_rows`` (SAD, or Birchfield-Tomasi with ``bt``): the reference."""
    out = records.outputs(*left.shape)
    rows.match_dsi_rows(
        padded(left, radius), padded(right, radius), records.dsi(dmin, ndisp, radius), bt,
        records.step_costs(occ2, slant2, five), 3, out,
    )  # fmt: skip
    return maps(out)


#: ``tests`` of ``match_band_rows`` for pins given from outside (``PINS_GIVEN``): no search.
PIN_TESTS = records.feature_tests(signal_steps=1)


def banded(left, right, dmin, ndisp, radius, occ2, five, slant2, partner=None, nchunks=2, bt=False):
    """``match_band_rows`` without pins (as ``dsi3``/``dsi5`` call it: ``tests`` None) or
    through the pins of ``partner`` (``PINS_GIVEN``); the Birchfield-Tomasi cost with
    ``bt``."""
    anchored = partner is not None
    out = records.outputs(*left.shape, partner=anchored)
    if anchored:
        out.partner[:] = partner
    # every argument given, as mbands._band_rows gives them: an omitted one is a type of its
    # own, and numba would compile (and the suite wait for) one more version of the kernel
    bands.match_band_rows(
        padded(left, radius), padded(right, radius), records.dsi(dmin, ndisp, radius),
        records.step_costs(occ2, slant2, five), bands.PINS_GIVEN if anchored else bands.FREE,
        PIN_TESTS if anchored else None, nchunks, out, None, True if bt else None, None,
    )  # fmt: skip
    return maps(out)


def segmented(left, right, dmin, ndisp, radius, occ2, five, slant2, partner, bt=False):
    """Per row, ``scanline_dp`` segment by segment through the pins, exactly as ``gcp_row``
    runs it (free start -> first pin -> ... -> last pin -> free end), five or three steps;
    the Birchfield-Tomasi cost with ``bt``."""
    height, width = left.shape
    disp, flags, total = outputs(height, width)
    left_p, right_p = padded(left, radius), padded(right, radius)
    cost = np.empty((width, ndisp))
    vcol = np.empty((width, ndisp), dtype=np.int32)
    path = dp.path_scratch(width, ndisp)
    step_costs = records.step_costs(occ2, slant2, five)
    for y in range(height):
        row_costs = costs.row_costs_bt if bt else costs.row_costs
        row_costs(left_p, right_p, y, dmin, ndisp, radius, vcol, cost, False)
        disp[y] = np.nan
        flags[y] = dp.FLAG_BORDER
        row_total = 0.0
        a = b = -1
        pins = [(x, int(partner[y, x])) for x in range(width) if partner[y, x] >= 0]
        for c, e in [*pins, (width, width)]:
            if c < width or a < width - 1:
                start, end = a >= 0, c < width
                n, t = dp.scanline_dp(
                    cost, dmin, step_costs,
                    a if start else 0, c if end else width - 1,
                    b if start else 0, e if end else width - 1,
                    start, end, path,
                )  # fmt: skip
                dp.apply_path(path, n, dmin, disp[y], flags[y])
                row_total += t
            if c < width:
                disp[y, c] = c - e
                flags[y, c] = 0
            a, b = c, e
        total[y] = row_total
    return disp, flags, total


def assert_same(expected, got):
    for name, e, g in zip(("disparity", "flags", "total"), expected, got, strict=True):
        assert e.dtype == g.dtype
        np.testing.assert_array_equal(g, e, err_msg=name)
        # bitwise, NaN where NaN
        assert e.tobytes() == g.tobytes(), name


def random_case(rng):
    """A random problem: sizes from 1 pixel, windows wider than the image, bands wider
    than the image, negative disparities, heights that are not a multiple of the band."""
    height = int(rng.integers(1, 21))
    width = int(rng.integers(1, 33))
    ndisp = int(rng.integers(1, 14))
    dmin = int(rng.integers(-10, 10))
    radius = int(rng.integers(0, 4))
    left = rng.integers(0, 4081, (height, width)).astype(np.int32)
    if rng.random() < 0.5:
        right = rng.integers(0, 4081, (height, width)).astype(np.int32)
    else:  # a shifted copy plus noise: paths with long runs, occlusions, slants
        right = np.roll(left, int(rng.integers(-3, 4)), axis=1)
        right = right + rng.integers(0, 60, (height, width)).astype(np.int32)
    occ2 = float(rng.integers(0, 4000))
    slant2 = float(rng.integers(0, 3000))
    return left, right, dmin, ndisp, radius, occ2, slant2


def random_pins(rng, height, width, dmin, ndisp, density):
    """Pins ``x -> j`` per row: increasing in x and in j, inside the image and the band."""
    partner = np.full((height, width), -1, dtype=np.int64)
    for y in range(height):
        last_j = -1
        for x in range(width):
            if rng.random() >= density:
                continue
            ks = [k for k in range(ndisp) if last_j < x - dmin - k < width]
            if not ks:
                continue
            # the band's edges (k = 0, k = ndisp - 1) often
            pick = rng.random()
            k = ks[0] if pick < 0.2 else ks[-1] if pick < 0.4 else int(rng.choice(ks))
            partner[y, x] = x - dmin - k
            last_j = x - dmin - k
    return partner


@pytest.mark.parametrize("five", [False, True], ids=["dsi3", "dsi5"])
@pytest.mark.parametrize("seed", range(40))
def test_band_equals_per_row_on_random_inputs(five, seed):
    rng = np.random.default_rng(7000 + seed)
    left, right, dmin, ndisp, radius, occ2, slant2 = random_case(rng)
    expected = per_row(left, right, dmin, ndisp, radius, occ2, five, slant2)
    for nchunks in (1, 3):
        got = banded(left, right, dmin, ndisp, radius, occ2, five, slant2, nchunks=nchunks)
        assert_same(expected, got)


def block_per_row(left, right, dmin, ndisp, radius, bt=False):
    """``match_block_rows`` (SAD, or Birchfield-Tomasi with ``bt``): the per-row kernel."""
    out = records.outputs(*left.shape)
    rows.match_block_rows(
        padded(left, radius), padded(right, radius), records.dsi(dmin, ndisp, radius), bt, 3, out
    )
    return maps(out)


def block_banded(left, right, dmin, ndisp, radius, nchunks=2, bt=False):
    out = records.outputs(*left.shape)
    bands.match_block_bands(
        padded(left, radius), padded(right, radius), records.dsi(dmin, ndisp, radius), nchunks,
        out, True if bt else None,
    )  # fmt: skip
    return maps(out)


def block_naive(left, right, dmin, ndisp, radius):
    """Winner-take-all in plain numpy on ``row_costs``: the first least cost of each pixel."""
    height, width = left.shape
    disp, flags, total = outputs(height, width)
    left_p, right_p = padded(left, radius), padded(right, radius)
    cost = np.empty((width, ndisp))
    vcol = np.empty((width, ndisp), dtype=np.int32)
    for y in range(height):
        costs.row_costs(left_p, right_p, y, dmin, ndisp, radius, vcol, cost, False)
        row_total = 0.0
        for x in range(width):
            k = int(np.argmin(cost[x]))  # the first of equal least costs
            if np.isinf(cost[x, k]):
                disp[y, x], flags[y, x] = np.nan, dp.FLAG_BORDER
            else:
                disp[y, x], flags[y, x] = dmin + k, 0
                row_total += cost[x, k]
        total[y] = row_total
    return disp, flags, total


@pytest.mark.parametrize("seed", range(40))
def test_band_block_equals_per_row_and_naive_on_random_inputs(seed):
    rng = np.random.default_rng(9000 + seed)
    left, right, dmin, ndisp, radius, _, _ = random_case(rng)
    expected = block_naive(left, right, dmin, ndisp, radius)
    assert_same(expected, block_per_row(left, right, dmin, ndisp, radius))
    for nchunks in (1, 3):
        assert_same(expected, block_banded(left, right, dmin, ndisp, radius, nchunks))


def test_band_block_breaks_ties_at_the_first_disparity_in_every_kind_of_column():
    # a flat pair: every cell of a column costs the same, so each pixel takes its first
    # finite cell; columns near the ends have truncated windows (rescaled costs, the
    # binary search) and the middle ones integer costs (the keyed minima)
    left = np.full((11, 40), 2000, dtype=np.int32)
    right = left.copy()
    right[3, 17] = 0  # one tie broken
    expected = block_naive(left, right, -3, 9, 2)
    got = block_banded(left, right, -3, 9, 2)
    assert_same(expected, got)
    x_lo, x_hi = band_costs._integer_columns(40, -3, 9, 2)
    assert 0 < x_lo < x_hi < 40  # both kinds of column occur
    # rows 6.. do not see the changed pixel: all their costs are 0, the first finite cell
    # (right pixel x - d inside the image) wins
    first = np.maximum(-3, np.arange(40) - 39).astype(np.float32)
    np.testing.assert_array_equal(got[0][6:], np.broadcast_to(first, (5, 40)))
    assert (got[0][:6] != first).any()  # and the changed pixel moves some matches


@pytest.mark.parametrize("five", [False, True], ids=["dsi3", "dsi5"])
@pytest.mark.parametrize("seed", range(40))
def test_band_with_pins_equals_the_segmented_dp(five, seed):
    rng = np.random.default_rng(8000 + seed)
    left, right, dmin, ndisp, radius, occ2, slant2 = random_case(rng)
    height, width = left.shape
    density = float(rng.choice([0.05, 0.2, 0.6, 1.0]))
    partner = random_pins(rng, height, width, dmin, ndisp, density)
    expected = segmented(left, right, dmin, ndisp, radius, occ2, five, slant2, partner)
    got = banded(left, right, dmin, ndisp, radius, occ2, five, slant2, partner)
    assert_same(expected, got)


@pytest.mark.parametrize("five", [False, True], ids=["dsi3", "dsi5"])
def test_pins_at_the_row_ends_adjacent_and_at_the_band_edges(five):
    rng = np.random.default_rng(5)
    height, width, dmin, ndisp, radius = 9, 14, -1, 5, 1
    left = rng.integers(0, 4081, (height, width)).astype(np.int32)
    right = rng.integers(0, 4081, (height, width)).astype(np.int32)
    partner = np.full((height, width), -1, dtype=np.int64)
    partner[0, 0] = 1  # x = 0, k = 0 (d = -1)
    partner[1, 13] = 10  # the last pixel, k = ndisp - 1
    partner[2, [3, 4, 5]] = [4, 5, 6]  # adjacent, each at k = 0
    partner[3, [3, 4]] = [0, 4]  # adjacent: k = 4, then k = 1
    partner[4, [0, 13]] = [0, 13]  # both ends
    partner[5, [6, 7]] = [3, 4]  # adjacent at k = ndisp - 1
    partner[6] = np.arange(width) + 1  # every pixel, k = 0 (the last one leaves the image)
    partner[6, width - 1] = -1
    partner[7, [2, 9]] = [3, 6]  # a gap the right pixels are skipped over
    # row 8: none
    assert all(0 <= x - j - dmin < ndisp for y, x in zip(*np.nonzero(partner >= 0), strict=True)
               for j in [partner[y, x]])  # fmt: skip
    # and a flat pair (every cost 0): at row 3's second anchor the c step from the anchor
    # before costs 3 occ2 and an e step over that anchor only slant2, so the e-step guard
    # decides the anchor's value (the scalar anchor of AVX2 adds e_off as the vector code)
    flat = np.full((height, width), 7, dtype=np.int32)
    for pair in ((left, right), (flat, flat)):
        for occ2, slant2 in ((0.0, 0.0), (500.0, 300.0), (4000.0, 2500.0), (4000.0, 10.0)):
            expected = segmented(*pair, dmin, ndisp, radius, occ2, five, slant2, partner)
            got = banded(*pair, dmin, ndisp, radius, occ2, five, slant2, partner)
            assert_same(expected, got)


def test_pins_of_the_ground_control_points_give_gcp_row(tmp_path):
    # the reference above is gcp_row's loop: check it against the kernel itself
    rng = np.random.default_rng(3)
    height, width, ndisp, radius = 11, 60, 9, 2
    base = rng.integers(0, 4081, (height, width + 8)).astype(np.int32)
    left, right = base[:, 4 : 4 + width], base[:, 1 : 1 + width]  # disparity 3
    right = right + rng.integers(0, 30, right.shape).astype(np.int32)
    out = records.outputs(height, width, partner=True)
    left_p, right_p = padded(left, radius), padded(right, radius)
    gcp.match_gcp_rows(
        left_p, right_p, records.dsi(0, ndisp, radius), False, records.step_costs(3000.0),
        records.feature_tests(uniqueness=1.2, var_floor=0.0, signal_steps=16), 2, out,
    )  # fmt: skip
    partner = out.partner
    assert (partner >= 0).sum() > height  # there are control points to go through
    expected = maps(out)
    assert_same(expected, segmented(left, right, 0, ndisp, radius, 3000.0, False, 0.0, partner))
    assert_same(expected, banded(left, right, 0, ndisp, radius, 3000.0, False, 0.0, partner))


def gcp_in_mode(mode, left, right, **kw):
    """``dsi3-gcp`` forced into one way of running (``mbands._search_band_mode``; 0: row by row)."""
    with mock.patch.object(mbands, "_search_band_mode", lambda params, width: mode):
        return dcstereo.match(left, right, **kw)


def gcp_bands_equal_rows(left, right, kw):
    """Assert that ``dsi3-gcp`` on the bands gives ``match_gcp_rows``' result; return it.

    The bands with their cost array (mode 2) and, for SAD, without it (mode 3: the
    left-right check on the two least costs of each right pixel).
    """
    expected = gcp_in_mode(0, left, right, **kw)
    modes = (2, 3) if kw.get("cost", "sad") == "sad" else (2,)
    for mode in modes:
        got = gcp_in_mode(mode, left, right, **kw)
        assert got.disparity.tobytes() == expected.disparity.tobytes(), mode
        np.testing.assert_array_equal(got.flags, expected.flags)
        np.testing.assert_array_equal(got.path_cost, expected.path_cost)
        np.testing.assert_array_equal(got.features, expected.features)
    return got


def test_gcp_runs_as_dc_does_by_the_band_array():
    # dc's bound on the kept array: past it the SAD costs are made twice (mode 3), the BT
    # cost runs row by row; and dsi3-gcp takes the mode that rule gives (the modes give
    # the same maps, so the call itself is watched)
    params = dcstereo.MatchParams(max_disparity=63, method="dsi3-gcp")
    assert mbands._search_band_mode(params, 1900) == 2
    assert mbands._search_band_mode(params, 2100) == 3
    wide = dcstereo.MatchParams(max_disparity=255, method="dsi3-gcp")
    assert mbands._search_band_mode(wide, 3000) == 3
    bt = dcstereo.MatchParams(max_disparity=63, method="dsi3-gcp", cost="bt")
    assert mbands._search_band_mode(bt, 1900) == 2
    assert mbands._search_band_mode(bt, 2100) == 0
    rng = np.random.default_rng(8)
    left = rng.integers(0, 256, (12, 40)).astype(np.uint8)
    right = np.roll(left, 3, axis=1)

    def modes_run(**kw):
        with (
            mock.patch.object(mbands, "_band_rows", wraps=mbands._band_rows) as bands,
            mock.patch.object(gcp, "match_gcp_rows", wraps=gcp.match_gcp_rows) as rows,
        ):
            dcstereo.match(left, right, max_disparity=7, method="dsi3-gcp", **kw)
        return [call.kwargs["mode"] for call in bands.call_args_list] + [0] * rows.call_count

    assert modes_run() == [2]
    assert modes_run(cost="bt") == [2]
    with mock.patch.object(mbands, "DC_BAND_BYTES", 0):  # the bound reaches the choice
        assert mbands._search_band_mode(params, 40) == 3
        assert mbands._search_band_mode(bt, 40) == 0
        assert modes_run() == [3]
        assert modes_run(cost="bt") == [0]


def test_gcp_diagonals_are_the_two_least_costs_of_each_right_pixel():
    # _gcp_diagonals over every column of a band against each right pixel's costs sorted:
    # the least, and the second counted with repeats (ties are common: small integers)
    rng = np.random.default_rng(21)
    nr = simd.BAND_ROWS
    for width, dmin, ndisp in ((30, 0, 7), (25, -4, 9), (12, 3, 20), (9, -12, 6), (16, 0, 1)):
        cost = rng.integers(0, 6, (width, ndisp + 2, nr)).astype(np.float64)
        cost[:, 0] = cost[:, -1] = np.inf
        least = np.full(width * nr, np.inf)
        second = np.full(width * nr, np.inf)
        flat = cost.ravel()
        for x in range(width):
            gcp._gcp_diagonals(
                flat, np.uint64(x * (ndisp + 2) * nr), x, dmin, ndisp, width, least, second
            )
        for j in range(width):
            for r in range(nr):
                values = sorted(
                    cost[j + dmin + k, k + 1, r] for k in range(ndisp) if 0 <= j + dmin + k < width
                )
                i = (width - 1 - j) * nr + r
                assert least[i] == (values[0] if values else np.inf)
                assert second[i] == (values[1] if len(values) > 1 else np.inf)


@pytest.mark.parametrize("cost", ["sad", "bt"])
@pytest.mark.parametrize("seed", range(6))
def test_gcp_on_bands_equals_the_row_kernel(cost, seed):
    # dsi3-gcp on the band kernels (the points of each row on the band's costs, the DP
    # through them) gives match_gcp_rows' maps, flags, path costs and points, bit for bit
    rng = np.random.default_rng(640 + seed)
    height, width = int(rng.integers(3, 30)), int(rng.integers(30, 70))
    shift = int(rng.integers(0, 6))
    texture = rng.integers(0, 256, (height, width + 16)).astype(np.uint8)
    left = texture[:, 8 : 8 + width]
    right = np.clip(texture[:, 8 + shift : 8 + shift + width] + rng.integers(-5, 6, left.shape),
                    0, 255).astype(np.uint8)  # fmt: skip
    kw = dict(
        max_disparity=int(rng.integers(shift, shift + 8)),
        min_disparity=int(rng.integers(-3, 1)),
        window=int(rng.choice([w for w in (1, 3, 5) if w <= min(height, width)])),
        method="dsi3-gcp",
        cost=cost,
        gcp_uniqueness=float(rng.choice([1.2, 3.0])),
        gcp_variance_floor=float(rng.choice([0.0, 50.0])),
    )
    got = gcp_bands_equal_rows(left, right, kw)
    assert len(got.features) > 0  # the DP goes through points


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    st.integers(1, 19),  # height
    st.integers(1, 30),  # width
    st.integers(0, 2**32 - 1),  # seed
    st.sampled_from(["sad", "bt"]),
    st.sampled_from([0.0, 1.2, 3.0]),  # gcp_uniqueness
    st.sampled_from([0.0, 50.0]),  # gcp_variance_floor
)
def test_gcp_on_bands_equals_the_row_kernel_at_any_size(
    height, width, seed, cost, uniqueness, floor
):
    # idle lanes, rows shorter than the window's reach, ranges past either end
    rng = np.random.default_rng(seed)
    window = int(rng.choice([w for w in (1, 3, 5) if w <= min(height, width)]))
    dmin = int(rng.integers(-(width - 1), width))
    dmax = int(rng.integers(dmin, width))
    shift = int(rng.integers(0, 4))
    texture = rng.integers(0, 256, (height, width + 4)).astype(np.uint8)
    left, right = texture[:, shift : shift + width], texture[:, :width]
    kw = dict(
        max_disparity=dmax, min_disparity=dmin, window=window, method="dsi3-gcp", cost=cost,
        gcp_uniqueness=uniqueness, gcp_variance_floor=floor,
    )  # fmt: skip
    gcp_bands_equal_rows(left, right, kw)


@st.composite
def problems(draw):
    height = draw(st.integers(1, 19))
    width = draw(st.integers(1, 24))
    ndisp = draw(st.integers(1, 10))
    dmin = draw(st.integers(-12, 12))
    radius = draw(st.integers(0, 3))
    five = draw(st.booleans())
    pinned = draw(st.booleans())
    seed = draw(st.integers(0, 2**32 - 1))
    return height, width, ndisp, dmin, radius, five, pinned, seed


@settings(max_examples=120, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(problems())
def test_any_size_band_equals_per_row(problem):
    height, width, ndisp, dmin, radius, five, pinned, seed = problem
    rng = np.random.default_rng(seed)
    left = rng.integers(0, 4081, (height, width)).astype(np.int32)
    right = rng.integers(0, 4081, (height, width)).astype(np.int32)
    occ2, slant2 = 2000.0, 800.0
    if pinned:
        partner = random_pins(rng, height, width, dmin, ndisp, 0.3)
        expected = segmented(left, right, dmin, ndisp, radius, occ2, five, slant2, partner)
    else:
        partner = None
        expected = per_row(left, right, dmin, ndisp, radius, occ2, five, slant2)
    assert_same(expected, banded(left, right, dmin, ndisp, radius, occ2, five, slant2, partner))


def test_band_costs_equal_row_costs():
    # the sums computed afresh, for bands of consecutive rows (past the image: the last row)
    rng = np.random.default_rng(11)
    for dmin, ndisp, radius, width in ((-3, 7, 2, 13), (4, 6, 1, 9), (0, 12, 3, 5), (-9, 4, 0, 6)):
        height = 11
        left = rng.integers(0, 4081, (height, width)).astype(np.int32)
        right = rng.integers(0, 4081, (height, width)).astype(np.int32)
        left_p, right_p = padded(left, radius), padded(right, radius)
        nr = simd.BAND_ROWS
        win = 2 * radius + 1
        nk = (ndisp + 2) * nr
        left_t = np.empty(win * (width + 2 * radius) * nr, dtype=np.int64)
        right_t = np.empty_like(left_t)
        rows = np.empty(win * nr, dtype=np.int64)
        spread = np.empty(2 * ndisp * nr, dtype=np.int64)
        vs = np.empty(width * ndisp * nr, dtype=np.int64)
        hsum = np.empty(ndisp * nr, dtype=np.int64)
        out = np.empty(width * nk)
        expected = np.empty((width, ndisp))
        vcol = np.empty((width, ndisp), dtype=np.int32)
        for y0 in range(0, height, nr):
            for t in range(win):
                rows[t * nr : (t + 1) * nr] = np.minimum(
                    y0 + t + np.arange(nr), left_p.shape[0] - 1
                )
            band_costs.band_lane_signals(left_p, right_p, rows, win, left_t, right_t)
            band_costs.band_lane_costs(left_t, right_t, width, dmin, ndisp, radius, spread,
                                          vs, False, hsum, out)  # fmt: skip
            band = out.reshape(width, ndisp + 2, nr)
            assert np.isinf(band[:, 0]).all() and np.isinf(band[:, -1]).all()
            for r in range(min(nr, height - y0)):
                costs.row_costs(left_p, right_p, y0 + r, dmin, ndisp, radius, vcol, expected,
                                   False)  # fmt: skip
                assert band[:, 1:-1, r].tobytes() == expected.tobytes()


@pytest.mark.parametrize("height", range(1, 18))
def test_lanes_of_any_height_and_more_chunks_than_bands(height):
    # each lane runs down its own rows (idle lanes when the height is not a multiple of the
    # band): every height 1..17, chunks of one band, and more chunks than bands
    rng = np.random.default_rng(900 + height)
    width, ndisp, dmin = 11, 6, -2
    left = rng.integers(0, 4081, (height, width)).astype(np.int32)
    right = rng.integers(0, 4081, (height, width)).astype(np.int32)
    for radius in (0, 1, 2):
        for five in (False, True):
            expected = per_row(left, right, dmin, ndisp, radius, 1500.0, five, 700.0)
            for nchunks in (1, 2, 3, 5, 40):
                got = banded(left, right, dmin, ndisp, radius, 1500.0, five, 700.0,
                             nchunks=nchunks)  # fmt: skip
                assert_same(expected, got)
        partner = random_pins(rng, height, width, dmin, ndisp, 0.3)
        expected = segmented(left, right, dmin, ndisp, radius, 1500.0, True, 700.0, partner)
        for nchunks in (1, 3, 40):
            got = banded(left, right, dmin, ndisp, radius, 1500.0, True, 700.0, partner, nchunks)
            assert_same(expected, got)


def load_band_signals(left_p, right_p, t, run, height, radius, rows, left_t, right_t):
    """``band_lane_signals`` at band step ``t`` as ``match_band_rows`` loads them (lane ``r``
    on row ``r * run + t``): the window rows at ``t == 0``, then the leaving and entering."""
    nr = simd.BAND_ROWS
    win = 2 * radius + 1
    if t == 0:
        for tt in range(win):
            rows[tt * nr : (tt + 1) * nr] = np.minimum(
                np.arange(nr) * run + tt, left_p.shape[0] - 1
            )
    else:
        y = np.arange(nr) * run + t
        rows[:nr] = np.where(y < height, y - 1, 0)
        rows[nr : 2 * nr] = np.where(y < height, y + 2 * radius, 0)
    band_costs.band_lane_signals(left_p, right_p, rows, win if t == 0 else 2, left_t, right_t)


@pytest.mark.parametrize("dtype", [np.int64, np.int32])
def test_incremental_lane_costs_equal_row_costs(dtype):
    # band_lane_costs moved down row by row (lane r on rows r * run + t) gives row_costs,
    # and band_lane_variance window_variance_row (both views), with int64 buffers and with
    # the int32 buffers of match_band_rows
    rng = np.random.default_rng(12)
    nr = simd.BAND_ROWS
    for dmin, ndisp, radius, width, height in (
        (-3, 7, 2, 13, 19), (4, 6, 1, 9, 8), (0, 12, 3, 5, 3), (-9, 4, 0, 6, 17), (2, 5, 1, 1, 9),
    ):  # fmt: skip
        left = rng.integers(0, 4081, (height, width)).astype(np.int32)
        right = rng.integers(0, 4081, (height, width)).astype(np.int32)
        left_p, right_p = padded(left, radius), padded(right, radius)
        win = 2 * radius + 1
        nk = (ndisp + 2) * nr
        left_t = np.empty(max(win, 2) * (width + 2 * radius) * nr, dtype=dtype)
        right_t = np.empty_like(left_t)
        rows = np.empty(max(win, 2) * nr, dtype=np.int64)
        spread = np.empty(2 * ndisp * nr, dtype=dtype)
        vs = np.empty(width * ndisp * nr, dtype=dtype)
        hsum = np.empty(ndisp * nr, dtype=dtype)
        out = np.empty(width * nk)
        expected = np.empty((width, ndisp))
        vcol = np.empty((width, ndisp), dtype=np.int32)
        colsum = np.empty((2, (width + 2 * radius) * nr))
        colsq = np.empty_like(colsum)
        hs = np.empty((2, width * nr))
        var = np.empty((2, width * nr))
        var_row = np.empty(width)
        col_row = np.empty((2, width + 2 * radius), dtype=np.int64)
        run = -(-height // nr)
        for t in range(run):
            load_band_signals(left_p, right_p, t, run, height, radius, rows, left_t, right_t)
            band_costs.band_lane_costs(left_t, right_t, width, dmin, ndisp, radius, spread,
                                          vs, t > 0, hsum, out)  # fmt: skip
            for v, sig_t in enumerate((left_t, right_t)):
                band_costs.band_lane_variance(sig_t, width, radius, 3, t > 0, colsum[v],
                                                 colsq[v], hs[0], hs[1], var[v])  # fmt: skip
            band = out.reshape(width, ndisp + 2, nr)
            assert np.isinf(band[:, 0]).all() and np.isinf(band[:, -1]).all()
            for r in range(nr):
                if r * run + t >= height:
                    continue
                costs.row_costs(left_p, right_p, r * run + t, dmin, ndisp, radius, vcol,
                                   expected, False)  # fmt: skip
                assert band[:, 1:-1, r].tobytes() == expected.tobytes()
                for v, signal_p in enumerate((left_p, right_p)):
                    features.window_variance_row(signal_p, r * run + t, radius, 3, col_row[0],
                                                 col_row[1], var_row, False)  # fmt: skip
                    lane = var[v].reshape(width, nr)[:, r]
                    if v == 1:  # the right view is stored right to left
                        lane = lane[::-1]
                    assert lane.tobytes() == var_row.tobytes()


@pytest.mark.parametrize("radius", [75, 76, 80])
def test_lane_variance_of_wide_windows_equals_the_integer_one(radius):
    # band_lane_variance's sums are integers in float64; past some 150 pixels a side
    # n * sq can leave float64's exact integers (side 153 is the first where it can on a
    # signal of 4080), and then the numerators are made again in int64: the values of
    # window_variance_row on windows below it (75) and past it (76, 80: they do),
    # summed afresh and moved down a row; and the search's variance of a window from its
    # integer sums (_window_variance), which makes the numerator in int64 at every size
    rng = np.random.default_rng(40 + radius)
    nr = simd.BAND_ROWS
    win = 2 * radius + 1
    assert 151**4 * 4080**2 < 2**53 <= 153**4 * 4080**2
    window_sums = ssd_in_form(simd.SSD_WIDE)
    width, height = 24, win + 2
    signal = np.where(rng.random((height + 1, width)) < 0.99, 4080, rng.integers(0, 4081))
    signal_p = padded(signal.astype(np.int32), radius)
    window_sq = np.lib.stride_tricks.sliding_window_view(signal_p.astype(np.int64) ** 2, (win, win))
    over = (win * win * window_sq.sum(axis=(2, 3)) >= 2**53).any()
    assert over == (radius > 75)
    sig_t = np.empty(win * (width + 2 * radius) * nr, dtype=np.int32)
    rows = np.empty(win * nr, dtype=np.int64)
    colsum, colsq = np.empty((2, (width + 2 * radius) * nr))
    hs = np.empty((2, width * nr))
    var = np.empty(width * nr)
    var_row = np.empty(width)
    col_row = np.empty((2, width + 2 * radius), dtype=np.int64)
    last = signal_p.shape[0] - 1
    for t in range(2):  # lane r on row r + t: afresh, then moved down
        if t == 0:
            rows[:] = np.minimum(np.arange(win)[:, None] + np.arange(nr), last).ravel()
        else:
            rows[:nr] = np.arange(nr)
            rows[nr : 2 * nr] = np.minimum(np.arange(nr) + win, last)
        nt = win if t == 0 else 2
        band_costs.band_lane_signals(signal_p, signal_p, rows, nt, sig_t, sig_t.copy())
        band_costs.band_lane_variance(sig_t, width, radius, 16, t > 0, colsum, colsq, hs[0],
                                         hs[1], var)  # fmt: skip
        for r in range(nr):  # (no lane's window reaches the padded signal's last row)
            features.window_variance_row(signal_p, r + t, radius, 16, col_row[0], col_row[1],
                                         var_row, False)  # fmt: skip
            assert var.reshape(width, nr)[:, r].tobytes() == var_row.tobytes(), (t, r)
            # the search's right-view variance: from the SSD's sums of the window
            n, norm = win * win, float(win * win) ** 2 * 16.0**2
            for x in range(width):
                _, sm, sq = window_sums(signal_p, signal_p, r + t, x, x, radius)
                assert features._window_variance(sm, sq, n, norm) == var_row[x], (t, r, x)
    wide = simd.SSD_WIDE
    _, sm, sq = simd._window_ssd(signal_p, signal_p, 1, 3, 3, radius, wide)  # twin
    assert (sm, sq) == tuple(window_sums(signal_p, signal_p, 1, 3, 3, radius)[1:])


def lane_cost_scratch(width, ndisp, radius):
    """int32 ``left_t``, ``right_t``, ``spread`` and the int64 ``rows`` of a band's cost pass."""
    nr = simd.BAND_ROWS
    left_t = np.empty(max(2 * radius + 1, 2) * (width + 2 * radius) * nr, dtype=np.int32)
    rows = np.empty(max(2 * radius + 1, 2) * nr, dtype=np.int64)
    return left_t, np.empty_like(left_t), rows, np.empty(2 * ndisp * nr, dtype=np.int32)


def test_block_match_on_made_costs_equals_the_one_on_the_band_array():
    # band_block_match making each column's costs (make_costs), then matching them, gives
    # band_block_match on band_lane_costs' array, bit for bit, band after band, and leaves
    # the vertical sums of band_lane_costs, from which band_lane_costs with SUMS_READY
    # makes the same array; the same with the moved columns made and matched at once
    # (fused: _moved_costs_keyed)
    rng = np.random.default_rng(13)
    nr = simd.BAND_ROWS
    for dmin, ndisp, radius, width, height in (
        (-3, 7, 2, 13, 19), (4, 6, 1, 9, 8), (0, 12, 3, 25, 3), (-9, 4, 0, 6, 17), (2, 5, 1, 1, 9),
        (0, 30, 2, 40, 20),
    ):  # fmt: skip
        # few levels: ties between disparities
        left = (rng.integers(0, 6, (height, width)) * 800).astype(np.int32)
        right = (rng.integers(0, 6, (height, width)) * 800).astype(np.int32)
        left_p, right_p = padded(left, radius), padded(right, radius)
        nk = (ndisp + 2) * nr
        x_int_lo, x_int_hi = band_costs._integer_columns(width, dmin, ndisp, radius)
        left_t, right_t, rows, spread = lane_cost_scratch(width, ndisp, radius)
        vs_array, vs_made, vs_fused = (
            np.empty(width * ndisp * nr, dtype=np.int32) for _ in range(3)
        )
        shift = band_costs._key_shift(ndisp + 2)
        assert band_costs._keys_fit(4000, radius, shift)
        fused = (x_int_lo, x_int_hi, shift)
        hsum = np.empty(ndisp * nr, dtype=np.int32)
        out, again = np.empty(width * nk), np.empty(width * nk)
        col = np.empty(nk)
        pre, suf = np.empty(nk), np.empty(nk)
        k_array, k_made, k_fused = (np.empty(width * nr, dtype=np.int64) for _ in range(3))
        r_array, r_made, r_fused = (np.empty(width * nr) for _ in range(3))
        run = -(-height // nr)
        for t in range(run):
            load_band_signals(left_p, right_p, t, run, height, radius, rows, left_t, right_t)
            band_costs.band_lane_costs(left_t, right_t, width, dmin, ndisp, radius, spread,
                                          vs_array, int(t > 0), hsum, out)  # fmt: skip
            band_match.band_block_match(out, width, ndisp, x_int_lo, x_int_hi, pre, suf,
                                           k_array, r_array)  # fmt: skip
            band_match.band_block_match(
                col, width, ndisp, x_int_lo, x_int_hi, pre, suf, k_made, r_made,
                (left_t, right_t, dmin, radius, spread, vs_made, int(t > 0), hsum),
            )  # fmt: skip
            band_match.band_block_match(
                col, width, ndisp, x_int_lo, x_int_hi, pre, suf, k_fused, r_fused,
                (left_t, right_t, dmin, radius, spread, vs_fused, int(t > 0), hsum), None, None,
                fused,
            )  # fmt: skip
            for k_got, r_got, vs_got in ((k_made, r_made, vs_made), (k_fused, r_fused, vs_fused)):
                np.testing.assert_array_equal(k_got, k_array)
                assert r_got.tobytes() == r_array.tobytes()
                assert vs_got.tobytes() == vs_array.tobytes()
            ready = band_costs.SUMS_READY
            band_costs.band_lane_costs(left_t, right_t, width, dmin, ndisp, radius, spread,
                                          vs_made, ready, hsum, again)  # fmt: skip
            assert again.tobytes() == out.tobytes()
            assert vs_made.tobytes() == vs_array.tobytes()


@pytest.mark.parametrize("guard", [0, 1, 3])
def test_block_match_of_the_wanted_columns_only(guard):
    # with wanted (band_strong_counts' counts), the columns within guard of a strong one
    # get the values of the full block match and the others those of an empty column;
    # the counts are those of a plain count over the lanes
    rng = np.random.default_rng(31 + guard)
    nr = simd.BAND_ROWS
    left_out = 0
    for width, ndisp in ((1, 3), (9, 5), (40, 12), (23, 30)):
        nk = (ndisp + 2) * nr
        cost = rng.integers(0, 9, (width, ndisp + 2, nr)).astype(np.float64)
        cost[:, [0, -1]] = np.inf
        cost[rng.random(cost.shape) < 0.1] = np.inf
        cost = cost.ravel()
        var = rng.random(width * nr) * 100.0
        var[rng.random(width * nr) < 0.97] = 0.0  # strong pixels are few: columns left out
        floor = 50.0
        counts = np.full(width + 1, -7, dtype=np.int64)
        divide_bands.band_strong_counts(var, width, floor, counts)
        strong = (var.reshape(width, nr) >= floor).any(axis=1)
        assert list(counts) == [0] + list(np.cumsum(strong))
        wanted = np.array(
            [strong[max(x - guard, 0) : x + guard + 1].any() for x in range(width)], dtype=bool
        )
        pre, suf = np.empty(nk), np.empty(nk)
        full_k, part_k = (np.empty(width * nr, dtype=np.int64) for _ in range(2))
        full_r, part_r = np.empty(width * nr), np.empty(width * nr)
        band_match.band_block_match(cost, width, ndisp, 0, width, pre, suf, full_k, full_r)
        band_match.band_block_match(
            cost, width, ndisp, 0, width, pre, suf, part_k, part_r, None, (counts, guard)
        )
        lanes = np.repeat(wanted, nr)
        np.testing.assert_array_equal(part_k[lanes], full_k[lanes])
        assert part_r[lanes].tobytes() == full_r[lanes].tobytes()
        assert (part_k[~lanes] == -1).all() and (part_r[~lanes] == 0.0).all()
        left_out += int((~wanted).sum())
    assert left_out > 0


@pytest.mark.parametrize("bt", [False, True], ids=["sad", "bt"])
def test_largest_window_sums_fit_the_int32_buffers(bt):
    # the largest window with the largest per-pixel cost everywhere (a white left view and
    # a black right one: SAD 4080 up to MAX_WINDOW, doubled BT 8160 up to MAX_BT_WINDOW),
    # in match_band_rows' int32 buffers, moved down a row too: every cost is
    # 4080 * window**2 (the summed integers just under 2**31) and none wraps around
    win = MAX_BT_WINDOW if bt else MAX_WINDOW
    most = 8160 if bt else 4080  # the largest summed integer of a pixel
    assert most * win**2 < 2**31 <= most * (win + 2) ** 2
    radius, width, ndisp, dmin = win // 2, win, 2, 0
    nr = simd.BAND_ROWS
    left_p = np.full((win + 1, width + 2 * radius), 4080, dtype=np.int32)
    right_p = np.zeros_like(left_p)
    left_t = np.empty(win * (width + 2 * radius) * nr, dtype=np.int32)
    right_t = np.empty_like(left_t)
    bounds = np.empty((12, (width + 2 * radius) * nr), dtype=np.int32)
    spread = np.empty(3 * ndisp * nr, dtype=np.int32)
    vs = np.empty(width * ndisp * nr, dtype=np.int32)
    hsum = np.empty(ndisp * nr, dtype=np.int32)
    out = np.empty(width * (ndisp + 2) * nr)
    for incremental in (False, True):
        rows = np.repeat(np.arange(win) + incremental, nr)[: (2 if incremental else win) * nr]
        band_costs.band_lane_signals(left_p, right_p, rows, rows.size // nr, left_t, right_t)
        if bt:
            band_costs.band_lane_costs_bt(left_t, right_t, width, dmin, ndisp, radius, bounds,
                                             spread, vs, incremental, hsum, out)  # fmt: skip
        else:
            band_costs.band_lane_costs(left_t, right_t, width, dmin, ndisp, radius,
                                          spread[: 2 * ndisp * nr], vs, incremental, hsum,
                                          out)  # fmt: skip
        band = out.reshape(width, ndisp + 2, nr)[:, 1:-1]
        finite = band[np.isfinite(band)]
        assert finite.size == (2 * width - 1) * nr  # d = 1 has no match at x = 0
        assert (finite == 4080.0 * win * win).all()


@pytest.mark.parametrize("dtype", [np.uint8, np.bool_, np.int32, np.int64, np.float64])
def test_scratch_starts_at_its_slot_of_the_page(dtype):
    page, step = 4096, scratch.PLACE_STEP
    offsets = set()
    for slot in (0, 1, 2, 26, 63, 64, 65):
        for n in (1, 17, 5000):
            arr = scratch._placed(n, dtype, slot)
            assert arr.shape == (n,) and arr.dtype == dtype
            assert arr.flags.c_contiguous and arr.flags.writeable
            assert arr.ctypes.data % page == slot * step % page
            arr[:] = 1  # the whole view is usable
        offsets.add(slot * step % page)
    assert len(offsets) == 5  # slots 64 apart share an offset (0 and 64, 1 and 65)


def test_band_kernels_run_as_plain_python():
    # NUMBA_DISABLE_JIT=1: the kernels are plain Python (coverage sees them)
    code = textwrap.dedent(
        """
        import numpy as np
        import test_band_kernels as t
        rng = np.random.default_rng(1)
        left, right = (rng.integers(0, 4081, (10, 9)).astype(np.int32) for _ in range(2))
        partner = t.random_pins(rng, 10, 9, -1, 4, 0.3)
        for five in (False, True):
            t.assert_same(t.per_row(left, right, -1, 4, 1, 900.0, five, 300.0),
                          t.banded(left, right, -1, 4, 1, 900.0, five, 300.0))
            # the pins in the cells' vector code (AVX-512) and in scalar code (AVX2), each
            # host's compiled kernel running only its own: both here
            for in_loop in (False, True):
                t.band_dp._PINS_IN_LOOP = in_loop
                t.assert_same(t.segmented(left, right, -1, 4, 1, 900.0, five, 300.0, partner),
                              t.banded(left, right, -1, 4, 1, 900.0, five, 300.0, partner))
            t.assert_same(t.per_row(left, right, -1, 4, 1, 900.0, five, 300.0, bt=True),
                          t.banded(left, right, -1, 4, 1, 900.0, five, 300.0, bt=True))
        texture = rng.integers(0, 256, (9, 24)).astype(np.uint8)
        left, right = texture[:, :-2], texture[:, 2:]
        dc = dict(max_disparity=4, window=3, method="dc")
        t.assert_same_dc(t.dc_by_rows(left, right, **dc), t.dcstereo.match(left, right, **dc))
        t.assert_same_dc(t.dc_by_rows(left, right, cost="bt", **dc),
                         t.dcstereo.match(left, right, cost="bt", **dc))
        t.assert_same(t.block_per_row(left.astype(np.int32), right.astype(np.int32), -1, 4, 1),
                      t.block_banded(left.astype(np.int32), right.astype(np.int32), -1, 4, 1))
        t.assert_same(
            t.block_per_row(left.astype(np.int32), right.astype(np.int32), -1, 4, 1, bt=True),
            t.block_banded(left.astype(np.int32), right.astype(np.int32), -1, 4, 1, bt=True))
        gcp = dict(max_disparity=4, window=3, method="dsi3-gcp")
        assert len(t.gcp_bands_equal_rows(left, right, gcp).features) > 0  # modes 2 and 3
        placed = t.scratch._placed(17, np.float64, 3)
        assert placed.shape == (17,) and placed.ctypes.data % 4096 == 3 * 448 % 4096
        print("ok")
        """
    )
    env = dict(os.environ, NUMBA_DISABLE_JIT="1")
    tests_dir = os.path.dirname(os.path.abspath(__file__))
    env["PYTHONPATH"] = tests_dir + os.pathsep + env.get("PYTHONPATH", "")
    done = subprocess.run(
        [sys.executable, "-c", code], env=env, capture_output=True, text=True, timeout=600
    )
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == "ok"


@pytest.mark.dataset
@pytest.mark.slow
@pytest.mark.parametrize("scene", ["tsukuba", "venus", "teddy", "cones"])
def test_band_equals_per_row_on_middlebury(middlebury_root, scene):
    data = load_middlebury(scene, root=middlebury_root.parent)
    left, right = matching_signal(data.left), matching_signal(data.right)
    ndisp = data.max_disparity + 1
    for five in (False, True):
        expected = per_row(left, right, 0, ndisp, 2, 8000.0, five, 4000.0)
        assert_same(expected, banded(left, right, 0, ndisp, 2, 8000.0, five, 4000.0))
    assert_same(block_per_row(left, right, 0, ndisp, 2), block_banded(left, right, 0, ndisp, 2))


# --------------------------------------------------------------------------- dc on bands


def check_block_match(values, cost, x_int_lo, x_int_hi, scratch, wta_k, wta_ratio):
    """``band_block_match`` on ``values`` (width, ndisp, R) in the padded ``cost`` vs the twin."""
    width, ndisp, nr = values.shape
    cost[:, 1:-1] = values
    band_match.band_block_match(cost.ravel(), width, ndisp, x_int_lo, x_int_hi, scratch[0],
                                   scratch[1], wta_k, wta_ratio)  # fmt: skip
    for x in range(width):
        ks, ratios = naive.naive_block_match(values[x])
        assert list(wta_k[x * nr : (x + 1) * nr]) == ks
        np.testing.assert_array_equal(wta_ratio[x * nr : (x + 1) * nr], ratios)


@pytest.mark.parametrize("seed", range(6))
def test_band_block_match_equals_the_naive_one(seed):
    rng = np.random.default_rng(300 + seed)
    nr = simd.BAND_ROWS
    for _ in range(20):
        ndisp = int(rng.integers(1, 40))
        width = int(rng.integers(1, 12))
        # few distinct values: ties everywhere, zeros, inf cells, whole inf columns
        cells = rng.integers(0, 4, (width, ndisp, nr)).astype(np.float64)
        cells[rng.random(cells.shape) < 0.2] = np.inf
        cells[:, :, 0] = np.inf if rng.random() < 0.3 else cells[:, :, 0]
        cost = np.full((width, ndisp + 2, nr), np.inf)  # the padding cells stay inf
        if rng.random() < 0.5:  # large integers: the keys' range
            cells = np.where(np.isinf(cells), cells, 2.0**31 - 1 - cells)
        wta_k = np.empty(width * nr, dtype=np.int64)
        wta_ratio = np.empty(width * nr)
        scratch = np.empty((2, (ndisp + 2) * nr))
        # integer costs: keyed columns, binary-searched ones, and a mix
        cut = int(rng.integers(0, width + 1))
        for x_int_lo, x_int_hi in ((0, width), (width, 0), (cut, width), (0, cut)):
            check_block_match(cells, cost, x_int_lo, x_int_hi, scratch, wta_k, wta_ratio)
        # fractional costs (the truncated windows): the binary search
        fractional = cells + rng.integers(0, 4, cells.shape) / 3.0
        check_block_match(fractional, cost, width, 0, scratch, wta_k, wta_ratio)


def test_keys_fit_says_whether_every_key_is_below_two_to_the_31():
    # the cost pass matches its columns only where (span * win**2 + 1) << shift < 2**31
    # (every key below the "none" of 2**31 - 1); exact at the edge, no overflow far past it
    for span in (0, 1, 4080, 65535, 2**20, 2**31, 2**40):
        for radius in (0, 1, 2, 31, 32, 362):
            for shift in (1, 2, 5, 7, 9, 12, 30, 31, 40):
                win = 2 * radius + 1
                expected = (span * win * win + 1) << shift < 2**31
                assert band_costs._keys_fit(span, radius, shift) == expected
                if expected:  # the edge: a cost one higher would not fit
                    limit = (2**31 >> shift) - 1  # the largest h + 1
                    assert band_costs._keys_fit(limit - 1, 0, shift)
                    assert not band_costs._keys_fit(limit, 0, shift)
    assert not band_costs._keys_fit(-1, 2, 5)
    assert band_costs._keys_fit(4080, 2, band_costs._key_shift(258))  # 256 disparities


@pytest.mark.parametrize("seed", range(4))
def test_signal_bounds_are_the_two_views_min_and_max(seed):
    # dc's keys are used only where the views' span lets them fit (_keys_fit), and its
    # search's SSD in 32-bit lanes where the span and the largest magnitude let the sums fit
    # (_narrow_sums); the bounds are the least and largest value of both views, wherever
    # each lies
    rng = np.random.default_rng(4200 + seed)
    for shape in ((1, 1), (3, 7), (40, 57)):
        low, high = sorted(rng.integers(-5000, 70000, 2))
        left = rng.integers(low, high + 1, shape).astype(np.int32)
        right = rng.integers(low, high + 1, shape).astype(np.int32)
        for a, b in ((left, right), (right, left), (left, left)):
            expected = (int(min(a.min(), b.min())), int(max(a.max(), b.max())))
            assert bands._signal_bounds(a, b) == expected
    extreme = np.array([[np.iinfo(np.int32).min]], dtype=np.int32)
    top = np.array([[np.iinfo(np.int32).max]], dtype=np.int32)
    low, high = bands._signal_bounds(extreme, top)
    assert high - low == 2**32 - 1  # int64: no overflow


def test_lane_costs_match_the_columns_they_move():
    # band_lane_costs given the block match's outputs makes the same costs, matches the
    # columns inside the range that it moves down a row (done 1) as band_block_match does
    # on its array, and leaves every other column's outputs alone (done 0), band after band
    rng = np.random.default_rng(14)
    nr = simd.BAND_ROWS
    matched = 0
    for dmin, ndisp, radius, width, height in (
        (-3, 7, 2, 30, 19), (4, 6, 1, 29, 24), (0, 12, 3, 25, 17), (-9, 4, 0, 16, 17),
        (0, 30, 2, 40, 20), (2, 5, 1, 1, 9),
    ):  # fmt: skip
        left = (rng.integers(0, 6, (height, width)) * 800).astype(np.int32)  # ties
        right = (rng.integers(0, 6, (height, width)) * 800).astype(np.int32)
        left_p, right_p = padded(left, radius), padded(right, radius)
        nk = (ndisp + 2) * nr
        x_lo, x_hi = band_costs._integer_columns(width, dmin, ndisp, radius)
        shift = band_costs._key_shift(ndisp + 2)
        left_t, right_t, rows, spread = lane_cost_scratch(width, ndisp, radius)
        vs_plain, vs_fused = (np.empty(width * ndisp * nr, dtype=np.int32) for _ in range(2))
        hsum = np.empty(ndisp * nr, dtype=np.int32)
        out, fused = np.empty(width * nk), np.empty(width * nk)
        pre, suf = np.empty(nk), np.empty(nk)
        wta_k, k_fused = (np.empty(width * nr, dtype=np.int64) for _ in range(2))
        wta_ratio, r_fused = np.empty(width * nr), np.empty(width * nr)
        done = np.full(width, 7, dtype=np.uint8)
        run = -(-height // nr)
        for t in range(run):
            load_band_signals(left_p, right_p, t, run, height, radius, rows, left_t, right_t)
            band_costs.band_lane_costs(left_t, right_t, width, dmin, ndisp, radius, spread,
                                          vs_plain, int(t > 0), hsum, out)  # fmt: skip
            band_match.band_block_match(out, width, ndisp, x_lo, x_hi, pre, suf, wta_k,
                                           wta_ratio)  # fmt: skip
            k_fused[:] = -99
            r_fused[:] = -5.0
            band_costs.band_lane_costs(
                left_t, right_t, width, dmin, ndisp, radius, spread, vs_fused, int(t > 0), hsum,
                fused, (x_lo, x_hi, shift, k_fused, r_fused, done),
            )  # fmt: skip
            assert fused.tobytes() == out.tobytes()
            assert vs_fused.tobytes() == vs_plain.tobytes()
            movable = [
                x_lo <= x < x_hi
                and band_costs._movable(x + radius, x - radius - 1, width, dmin, ndisp, t > 0)
                for x in range(width)
            ]
            np.testing.assert_array_equal(done, np.array(movable, dtype=np.uint8))
            for x in range(width):
                lanes = slice(x * nr, (x + 1) * nr)
                if done[x]:
                    np.testing.assert_array_equal(k_fused[lanes], wta_k[lanes])
                    assert r_fused[lanes].tobytes() == wta_ratio[lanes].tobytes()
                else:
                    assert (k_fused[lanes] == -99).all() and (r_fused[lanes] == -5.0).all()
            matched += done.sum()
            # band_block_match told which columns are done fills in exactly the others
            band_match.band_block_match(fused, width, ndisp, x_lo, x_hi, pre, suf, k_fused,
                                           r_fused, None, None, done)  # fmt: skip
            np.testing.assert_array_equal(k_fused, wta_k)
            assert r_fused.tobytes() == wta_ratio.tobytes()
    assert matched > 100


def naive_feature_mask(var_l, wta_k, wta_ratio, width, dmin, radius, var_floor, uniq, guard):
    """The cheap up-front tests of ``divide_row``, one pixel at a time: the twin of the mask."""
    nr = simd.BAND_ROWS
    keep = np.zeros(width * nr, dtype=np.uint8)
    for r in range(nr):
        for x in range(radius, width - radius):
            i = x * nr + r
            k = wta_k[i]
            if not var_l[i] >= var_floor or k < 0 or wta_ratio[i] < uniq:
                continue
            if not radius <= x - dmin - k <= width - 1 - radius:
                continue
            neighbours = [min(max(x2, 0), width - 1) for x2 in (x - guard, x + guard)]
            if guard > 0 and any(
                wta_k[x2 * nr + r] < 0
                or abs(wta_k[x2 * nr + r] - k) > 1
                or wta_ratio[x2 * nr + r] < uniq
                for x2 in neighbours
            ):
                continue
            keep[i] = 1
    return keep


@pytest.mark.parametrize("seed", range(6))
def test_band_feature_mask_equals_the_naive_one(seed):
    rng = np.random.default_rng(500 + seed)
    nr = simd.BAND_ROWS
    for _ in range(20):
        width = int(rng.integers(1, 30))
        radius = int(rng.integers(0, 4))
        guard = int(rng.integers(0, 6))
        dmin = int(rng.integers(-5, 6))
        ndisp = int(rng.integers(1, 12))
        var_l = rng.integers(0, 5, width * nr).astype(np.float64)
        wta_k = rng.integers(-1, ndisp, width * nr).astype(np.int64)
        # neighbours often agree, so that the guard passes now and then
        wta_k[nr:] = np.where(rng.random(wta_k.size - nr) < 0.6, wta_k[:-nr], wta_k[nr:])
        wta_ratio = rng.choice([0.0, 1.0, 1.5, 2.0, np.inf], width * nr)
        tests = records.feature_tests(ser_min=1.0, vs_max=1.0, vs_relative=True, var_floor=2.0,
                                      lr_check=True, uniqueness=1.5, edge_guard=guard,
                                      signal_steps=4)  # fmt: skip
        keep = np.full(width * nr, 7, dtype=np.uint8)
        divide_bands.band_feature_mask(var_l, wta_k, wta_ratio, width, dmin, radius, tests, keep)
        expected = naive_feature_mask(var_l, wta_k, wta_ratio, width, dmin, radius, 2.0, 1.5, guard)
        np.testing.assert_array_equal(keep, expected)


def dc_by_rows(left, right, **options):
    """``dc`` through the row-by-row kernel (``divide.match_dc_rows``): the reference."""
    return dc_in_mode(0, left, right, **options)


def dc_in_mode(mode, left, right, **options):
    """``dc`` row by row (0), on bands with the band's cost array (2) or without it (3)."""
    with mock.patch.object(mdc, "_dc_band_mode", lambda params, width: mode):
        return dcstereo.match(left, right, **{"method": "dc", **options})


def assert_same_dc(expected, got):
    assert got.disparity.tobytes() == expected.disparity.tobytes()
    np.testing.assert_array_equal(got.flags, expected.flags)
    np.testing.assert_array_equal(got.features, expected.features)
    # the cost of the whole path through the pairs on both paths (the row kernel counts
    # the intervals with no left pixel inside: the end pair's match, the right pixels
    # skipped), summed in another order
    np.testing.assert_allclose(got.path_cost, expected.path_cost, rtol=1e-12, atol=0)


DC_OPTIONS = [
    {},
    {"lr_check": True},
    {"edge_guard": 0, "lr_check": True},
    {"vs_relative": False, "vs_max": 80.0, "ser_min": 2.0, "lr_check": True},
    {"feature_floor": 0.0, "uniqueness": 1.2, "edge_guard": 1},
]


@pytest.mark.parametrize(
    ("cost", "seed"), [("sad", seed) for seed in range(8)] + [("bt", seed) for seed in range(4)]
)
def test_dc_on_bands_equals_the_row_kernel(cost, seed):
    # the band path (features on the band's costs, then the pinned band DP) gives the
    # pairs, disparities and flags of the row-by-row path, which fills each interval, with
    # the band's cost array (mode 2) and without it (mode 3: no left-right check; SAD only,
    # the Birchfield-Tomasi cost needs the array; its half-integer costs are never keyed)
    rng = np.random.default_rng(700 + seed)
    modes = (2, 3) if cost == "sad" else (2,)
    accepted = 0
    for options in DC_OPTIONS:
        height = int(rng.integers(5, 30))
        width = int(rng.integers(14, 60))
        shift = int(rng.integers(0, 6))
        texture = rng.integers(0, 256, (height, width + 16)).astype(np.uint8)
        left = texture[:, 8 : 8 + width]
        noise = rng.integers(-6, 7, (height, width))
        right = texture[:, 8 + shift : 8 + shift + width].astype(int) + noise
        right = np.clip(right, 0, 255).astype(np.uint8)
        kw = dict(
            max_disparity=int(rng.integers(shift, shift + 8)),
            min_disparity=int(rng.integers(-3, 1)),
            window=int(rng.choice([1, 3, 5])),
            cost=cost,
            **options,
        )
        expected = dc_by_rows(left, right, **kw)
        for mode in (2,) if options.get("lr_check") else modes:
            got = dc_in_mode(mode, left, right, **kw)
            assert_same_dc(expected, got)
        # one chunk: its bands after the first move the sums down a row, and the pass that
        # makes the costs (mode 2: the cost pass; mode 3: the block match) block-matches
        # the columns it moves (with 8 chunks these rows are one band each)
        with mock.patch.object(mbands, "_band_chunks", lambda height: 1):
            for mode in (2,) if options.get("lr_check") else modes:
                assert_same_dc(expected, dc_in_mode(mode, left, right, **kw))
        accepted += len(got.features)
    assert accepted > 0


@pytest.mark.parametrize("seed", range(3))
def test_dc_on_bands_rejects_crossing_pairs_as_the_row_kernel(seed):
    # a left patch copied into the right view far left of its true match: its pixels match
    # the copy exactly (SER inf), and the textured pixels left of the patch match their
    # true pixels, to the right of the copy. Those pairs cross, so the search of each row
    # must reject some, where a row in order accepts every candidate at once; both as the
    # row kernel
    rng = np.random.default_rng(90 + seed)
    height, width = 24, 64
    texture = rng.integers(0, 256, (height, width + 40)).astype(np.uint8)
    left = texture[:, 20 : 20 + width]
    right = texture[:, 16 : 16 + width].astype(int) + rng.integers(-4, 5, (height, width))
    a, size, offset = int(rng.integers(28, 40)), int(rng.integers(7, 11)), 16
    right[:, a - offset : a - offset + size] = left[:, a : a + size]  # d = 16 for the patch
    right = np.clip(right, 0, 255).astype(np.uint8)  # d = -4 elsewhere
    kw = dict(max_disparity=24, min_disparity=-6, window=3)
    expected = dc_by_rows(left, right, **kw)
    pairs = expected.features
    crossing = 0
    for y in range(height):
        row = pairs[pairs[:, 0] == y]
        copy = row[row[:, 1] - row[:, 2] == offset]  # pairs on the patch
        true = row[(row[:, 1] < a) & (row[:, 1] - row[:, 2] == -4)]
        crossing += len(copy) > 0 and len(true) > 0 and true[:, 2].max() >= copy[:, 2].min()
    assert crossing == 0  # the reference keeps the order, and
    on_patch = pairs[pairs[:, 1] - pairs[:, 2] == offset]
    assert len(np.unique(on_patch[:, 0])) >= 3  # the patch is matched in some rows
    for chunks in (1, 8):
        with mock.patch.object(mbands, "_band_chunks", lambda height, c=chunks: c):
            assert_same_dc(expected, dc_in_mode(2, left, right, **kw))
    assert_same_dc(expected, dc_in_mode(3, left, right, **kw))


@pytest.mark.parametrize("window", [63, 65])
def test_dc_on_bands_with_keys_too_wide_for_32_bits(window):
    # at 62 disparities (64 blocks: keys (h << 7) | j) a window of 63 of the matching
    # signal's 4080 still fits the cost pass's 32-bit keys and one of 65 does not, so the
    # separate block match takes every column; both give the row kernel's results
    rng = np.random.default_rng(62 + window)
    texture = rng.integers(0, 256, (66, 190)).astype(np.uint8)
    texture[0, :2] = 0, 255  # the signal's whole span, 0 .. 4080
    left, right = texture[:, 8:178], texture[:, 20:]  # d = 12
    shift = band_costs._key_shift(64)
    assert band_costs._keys_fit(4080, window // 2, shift) == (window == 63)
    kw = dict(max_disparity=61, window=window, feature_floor=0.0)
    expected = dc_by_rows(left, right, **kw)
    with mock.patch.object(mbands, "_band_chunks", lambda height: 1):
        got = dc_in_mode(2, left, right, **kw)
    assert_same_dc(expected, got)
    assert len(got.features) > 0


@pytest.mark.parametrize("steps", [12, 16])
def test_dc_on_bands_scales_ser_as_the_row_kernel(steps):
    # SER divides the variances by the SSD over steps**2: for a power of two the band path
    # multiplies the variances by steps**2 instead (one division fewer), for 12 it divides;
    # both give the row kernel's pairs and SERs. (The signal keeps its 16 steps: only the
    # tests' scale changes.)
    rng = np.random.default_rng(60)
    texture = rng.integers(0, 256, (12, 56)).astype(np.uint8)
    left = texture[:, 2:50]
    noise = rng.integers(-6, 7, left.shape)  # finite SERs
    right = np.clip(texture[:, 6:54].astype(int) + noise, 0, 255).astype(np.uint8)  # d = 4
    kw = dict(max_disparity=7, window=5)
    with (
        mock.patch.object(mdc, "SIGNAL_STEPS", steps),
        mock.patch.object(mbands, "SIGNAL_STEPS", steps),
    ):
        expected = dc_by_rows(left, right, **kw)
        got = dc_in_mode(2, left, right, **kw)
    assert_same_dc(expected, got)
    assert len(got.features) > 20


def test_ser_scaled_by_a_power_of_two_is_one_division():
    # what the band path relies on: t / (y / s) == (t * s) / y when s is a power of two
    # (both scalings exact), on SSDs and variance sums of the matching signal's sizes;
    # with s = 144 the two forms differ somewhere
    rng = np.random.default_rng(61)
    total = rng.random(200_000) * 1e7
    ssd = rng.integers(1, 2**40, 200_000).astype(np.float64)
    for s in (1.0, 4.0, 256.0, 65536.0):
        assert np.array_equal(total / (ssd / s), (total * s) / ssd)
    assert not np.array_equal(total / (ssd / 144.0), (total * 144.0) / ssd)


@pytest.mark.dataset
@pytest.mark.slow
@pytest.mark.parametrize("scene", ["tsukuba", "venus", "teddy", "cones"])
def test_dc_on_bands_equals_the_row_kernel_on_middlebury(middlebury_root, scene):
    data = load_middlebury(scene, root=middlebury_root.parent)
    for options in (DC_OPTIONS[0], DC_OPTIONS[3], {"window": 7, "min_disparity": 2}):
        kw = dict(max_disparity=data.max_disparity, method="dc", **options)
        expected = dc_by_rows(data.left, data.right, **kw)
        got = dcstereo.match(data.left, data.right, **kw)
        assert len(got.features) > 1000
        assert_same_dc(expected, got)
        if not options.get("lr_check"):
            assert_same_dc(expected, dc_in_mode(3, data.left, data.right, **kw))


def test_dc_keeps_the_band_cost_array_while_it_fits_the_caches():
    # a band's costs are width x (D + 2) x 8 float64: 450 x 66 x 64 bytes (1.8 MiB) and
    # 1900 x 66 x 64 (7.7 MiB) are kept (mode 2); 2100 x 66 x 64 (8.5 MiB) and 3000 x 258 x
    # 64 (47 MiB) are made twice instead (mode 3), or, with the left-right check, which
    # reads the array, kept all the same (2); row by row (0): the options the band search
    # does not implement
    params = dcstereo.MatchParams(max_disparity=63, method="dc")
    assert mdc._dc_band_mode(params, 450) == 2
    assert mdc._dc_band_mode(params, 1900) == 2
    assert mdc._dc_band_mode(params, 2100) == 3
    assert mdc._dc_band_mode(dcstereo.MatchParams(max_disparity=255, method="dc"), 3000) == 3
    assert (
        mdc._dc_band_mode(dcstereo.MatchParams(max_disparity=255, lr_check=True, method="dc"), 3000)
        == 2
    )
    assert (
        mdc._dc_band_mode(dcstereo.MatchParams(max_disparity=63, lr_check=True, method="dc"), 450)
        == 2
    )
    for options in ({"max_candidates": 5}, {"uniqueness": 0.0}, {"method": "dc-linear"}):
        params = dcstereo.MatchParams(max_disparity=63, **{"method": "dc", **options})
        assert mdc._dc_band_mode(params, 450) == 0
    # the Birchfield-Tomasi cost needs the band's cost array: kept past the caches, row by
    # row only past the memory bound (127100 columns of 66 disparities: 512 MiB)
    bt = dcstereo.MatchParams(max_disparity=63, cost="bt", method="dc")
    assert mdc._dc_band_mode(bt, 1900) == 2
    assert mdc._dc_band_mode(bt, 2100) == 2
    assert mdc._dc_band_mode(bt, 127100) == 2
    assert mdc._dc_band_mode(bt, 127101) == 0
    lr = dcstereo.MatchParams(max_disparity=63, lr_check=True, method="dc")
    assert mdc._dc_band_mode(lr, 127100) == 2
    assert mdc._dc_band_mode(lr, 127101) == 0


def test_band_cost_arrays_fit_the_memory_bound_together():
    # each running chunk makes one band cost array, so the chunks of the kernels that make
    # it are capped to the arrays BAND_ARRAY_BYTES holds (at least one); where one array
    # alone does not fit, the rows run one at a time; the maps never change
    params = dcstereo.MatchParams(max_disparity=7, cost="bt", method="dc")
    one = mbands._band_bytes(params, 40)
    assert one == 40 * 10 * simd.BAND_ROWS * 8
    rng = np.random.default_rng(12)
    left = rng.integers(0, 256, (48, 40)).astype(np.uint8)  # 6 bands
    right = np.roll(left, 3, axis=1)

    def chunks_run(method, **kw):
        with (
            mock.patch.object(bands, "match_band_rows", wraps=bands.match_band_rows) as band_calls,
            mock.patch.object(bands, "match_block_bands", wraps=bands.match_block_bands) as blocks,
        ):
            got = dcstereo.match(left, right, max_disparity=7, method=method, **kw)
        used = [c.args[6] for c in band_calls.call_args_list] + [
            c.args[3] for c in blocks.call_args_list
        ]
        return used, got

    cases = [
        ("block", {"cost": "bt"}, 2), ("dsi3", {"cost": "bt"}, 2), ("dsi5", {"cost": "bt"}, 2),
        ("dc", {"cost": "bt"}, 2), ("dc", {}, 2), ("dc", {"lr_check": True}, 2),
        ("dsi3-gcp", {}, 2), ("dsi5", {}, 6), ("block", {}, 6),
    ]  # fmt: skip
    with mock.patch.object(mbands, "_band_chunks", lambda height: 6):
        assert mbands._array_chunks(params, (48, 40)) == 6
        for method, kw, capped in cases:
            expected = chunks_run(method, **kw)
            assert expected[0] == [6]
            with mock.patch.object(mbands, "BAND_ARRAY_BYTES", 3 * one - 1):
                assert mbands._array_chunks(params, (48, 40)) == 2
                used, got = chunks_run(method, **kw)
            assert used == [capped], (method, kw)
            assert got.disparity.tobytes() == expected[1].disparity.tobytes()
            np.testing.assert_array_equal(got.flags, expected[1].flags)
            np.testing.assert_array_equal(got.features, expected[1].features)
        for method in ("block", "dsi5", "dc"):
            expected = chunks_run(method, cost="bt")[1]
            with mock.patch.object(mbands, "BAND_ARRAY_BYTES", one - 1):  # not one array: rows
                assert not mbands._band_array_fits(params, 40)
                used, got = chunks_run(method, cost="bt")
            assert used == []
            assert got.disparity.tobytes() == expected.disparity.tobytes()
            np.testing.assert_array_equal(got.flags, expected.flags)


# --------------------------------------------------------------------------- Birchfield-Tomasi


def test_band_lane_costs_bt_equal_row_costs_bt():
    # band_lane_costs_bt afresh, then moved down row by row (lane r on rows r * run + t),
    # gives row_costs_bt bit for bit: halved doubled sums, inf outside the right image and
    # in the padding cells, truncated windows rescaled; widths from 1, windows wider than
    # the image, every disparity outside it, the extreme signal values
    rng = np.random.default_rng(31)
    nr = simd.BAND_ROWS
    for dmin, ndisp, radius, width, height in (
        (-3, 7, 2, 13, 19), (4, 6, 1, 9, 8), (0, 12, 3, 5, 3), (-9, 4, 0, 6, 17),
        (2, 5, 1, 1, 9), (0, 30, 2, 40, 30), (20, 3, 1, 10, 9),
    ):  # fmt: skip
        for low, high in ((0, 4081), (0, 2), (4079, 4081)):
            left = rng.integers(low, high, (height, width)).astype(np.int32)
            right = rng.integers(low, high, (height, width)).astype(np.int32)
            left_p, right_p = padded(left, radius), padded(right, radius)
            win = 2 * radius + 1
            width_p = width + 2 * radius
            left_t = np.empty(max(win, 2) * width_p * nr, dtype=np.int32)
            right_t = np.empty_like(left_t)
            rows = np.empty(max(win, 2) * nr, dtype=np.int64)
            bounds = np.empty((12, width_p * nr), dtype=np.int32)
            spread = np.empty(3 * ndisp * nr, dtype=np.int32)
            vs = np.empty(width * ndisp * nr, dtype=np.int32)
            hsum = np.empty(ndisp * nr, dtype=np.int32)
            out = np.empty(width * (ndisp + 2) * nr)
            expected = np.empty((width, ndisp))
            vcol = np.empty((width, ndisp), dtype=np.int32)
            run = -(-height // nr)
            for t in range(run):
                load_band_signals(left_p, right_p, t, run, height, radius, rows, left_t, right_t)
                band_costs.band_lane_costs_bt(left_t, right_t, width, dmin, ndisp, radius,
                                                 bounds, spread, vs, t > 0, hsum, out)  # fmt: skip
                band = out.reshape(width, ndisp + 2, nr)
                assert np.isinf(band[:, 0]).all() and np.isinf(band[:, -1]).all()
                for r in range(nr):
                    if r * run + t >= height:
                        continue
                    costs.row_costs_bt(left_p, right_p, r * run + t, dmin, ndisp, radius,
                                          vcol, expected, False)  # fmt: skip
                    assert band[:, 1:-1, r].tobytes() == expected.tobytes()


@pytest.mark.parametrize("five", [False, True], ids=["dsi3", "dsi5"])
@pytest.mark.parametrize("seed", range(20))
def test_band_bt_equals_per_row_bt_on_random_inputs(five, seed):
    rng = np.random.default_rng(9100 + seed)
    left, right, dmin, ndisp, radius, occ2, slant2 = random_case(rng)
    expected = per_row(left, right, dmin, ndisp, radius, occ2, five, slant2, bt=True)
    for nchunks in (1, 3):
        got = banded(left, right, dmin, ndisp, radius, occ2, five, slant2, nchunks=nchunks,
                     bt=True)  # fmt: skip
        assert_same(expected, got)


@pytest.mark.parametrize("five", [False, True], ids=["dsi3", "dsi5"])
@pytest.mark.parametrize("seed", range(12))
def test_band_bt_with_pins_equals_the_segmented_bt_dp(five, seed):
    rng = np.random.default_rng(9200 + seed)
    left, right, dmin, ndisp, radius, occ2, slant2 = random_case(rng)
    height, width = left.shape
    partner = random_pins(rng, height, width, dmin, ndisp, float(rng.choice([0.1, 0.5])))
    expected = segmented(left, right, dmin, ndisp, radius, occ2, five, slant2, partner, bt=True)
    got = banded(left, right, dmin, ndisp, radius, occ2, five, slant2, partner, bt=True)
    assert_same(expected, got)


@pytest.mark.parametrize("seed", range(20))
def test_band_block_bt_equals_per_row_bt_on_random_inputs(seed):
    rng = np.random.default_rng(9300 + seed)
    left, right, dmin, ndisp, radius, _, _ = random_case(rng)
    expected = block_per_row(left, right, dmin, ndisp, radius, bt=True)
    for nchunks in (1, 3):
        got = block_banded(left, right, dmin, ndisp, radius, nchunks=nchunks, bt=True)
        assert_same(expected, got)


def test_band_bt_refuses_the_mode_without_a_cost_array():
    left = np.zeros((4, 6), dtype=np.int32)
    out = records.outputs(4, 6, pairs=True)
    with pytest.raises(ValueError, match="Birchfield-Tomasi cost needs the band's cost array"):
        bands.match_band_rows(
            padded(left, 1), padded(left, 1), records.dsi(0, 3, 1),
            records.step_costs(100.0, 50.0, True), bands.SEARCH_TWICE, PIN_TESTS, 1, out, None,
            True, None,
        )  # fmt: skip


def test_bt_runs_on_bands_while_the_cost_array_fits():
    # block/dsi3/dsi5 with BT make the band's cost array, 66 x 64 bytes a column here:
    # 127100 columns (512.0 MiB) fit the memory bound, one more runs row by row (both give
    # the same map); past the caches (2100 columns, 8.5 MiB) the array is still made
    params = dcstereo.MatchParams(max_disparity=63, cost="bt", method="dc")
    assert mbands._band_bytes(params, 2100) == 2100 * 66 * 64
    assert mbands._band_array_fits(params, 2100)
    assert mbands._band_array_fits(params, 127100)
    assert not mbands._band_array_fits(params, 127101)
    rng = np.random.default_rng(5)
    left = rng.integers(0, 256, (12, 40)).astype(np.uint8)
    right = np.roll(left, 3, axis=1)
    for method in ("block", "dsi3", "dsi5"):
        band = dcstereo.match(left, right, max_disparity=7, method=method, cost="bt")
        with mock.patch.object(mbands, "BAND_ARRAY_BYTES", 0):
            rows = dcstereo.match(left, right, max_disparity=7, method=method, cost="bt")
        assert band.disparity.tobytes() == rows.disparity.tobytes()
        np.testing.assert_array_equal(band.flags, rows.flags)
        np.testing.assert_array_equal(band.path_cost, rows.path_cost)


@pytest.mark.dataset
@pytest.mark.slow
@pytest.mark.parametrize("scene", ["tsukuba", "venus", "teddy", "cones"])
def test_bt_on_bands_equals_the_row_kernels_on_middlebury(middlebury_root, scene):
    data = load_middlebury(scene, root=middlebury_root.parent)
    left, right = matching_signal(data.left), matching_signal(data.right)
    ndisp = data.max_disparity + 1
    for five in (False, True):
        expected = per_row(left, right, 0, ndisp, 2, 8000.0, five, 4000.0, bt=True)
        assert_same(expected, banded(left, right, 0, ndisp, 2, 8000.0, five, 4000.0, bt=True))
    assert_same(
        block_per_row(left, right, 0, ndisp, 2, bt=True),
        block_banded(left, right, 0, ndisp, 2, bt=True),
    )
    kw = dict(max_disparity=data.max_disparity, cost="bt", method="dc")
    expected = dc_by_rows(data.left, data.right, **kw)
    got = dcstereo.match(data.left, data.right, **kw)
    assert len(got.features) > 1000
    assert_same_dc(expected, got)
    for cost in ("sad", "bt"):  # dsi3-gcp: its points and DP on the bands, as row by row
        kw = dict(max_disparity=data.max_disparity, method="dsi3-gcp", cost=cost)
        got = gcp_bands_equal_rows(data.left, data.right, kw)
        assert len(got.features) > 1000
