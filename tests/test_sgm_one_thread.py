"""The one-thread sweep (paths from below and the final pass fused) against the two passes."""

import numpy as np
import pytest

from dcstereo.aggregate import sgm as sgm_kernels

LANES = 16


def _volume(rng, height, width, lanes, high):
    cost = rng.integers(0, high, height * width * lanes).astype(np.int16)
    luma = rng.integers(0, 4081, (height, width)).astype(np.int32)
    table = rng.integers(20, 400, 4081).astype(np.int64)
    return cost, luma, table


def _outputs(height, width, margin):
    return (
        np.full((height, width), -5, np.int16),
        np.full((height, width), -5, np.int16),
        np.full((height, width), -5.0, np.float32),
        np.full((height, width if margin else 0), -5.0, np.float32),
    )


def _choose(cost, luma, table, diagonals, rows, cols, ndisp, subpixel, margin, threads):
    """``paths_and_choices`` of a strip's rows ``rows`` and columns ``cols``, its outputs."""
    height, width = luma.shape
    down, up = np.full_like(cost, -9), np.full_like(cost, -9)
    out = _outputs(height + 3, width + 2, margin)  # written at an offset (1, 2)
    sgm_kernels.paths_and_choices(
        cost, luma, down, up, *rows, *cols, -2, ndisp, 30, table, diagonals, subpixel, *out,
        1, 2, threads,
    )  # fmt: skip
    return out, up


@pytest.mark.parametrize("diagonals", [True, False])
@pytest.mark.parametrize("subpixel", [0, 1, 2])
def test_one_thread_sweep_equals_the_two_passes(diagonals, subpixel):
    rng = np.random.default_rng(10 * diagonals + subpixel)
    for height, width in [(1, 1), (1, 9), (7, 1), (5, 3), (6, 7), (9, 40), (12, 12)]:
        for lanes, ndisp in ((LANES, 11), (3 * LANES, 40)):
            # costs to 12000: the sums of three paths saturate at the int16 bound
            cost, luma, table = _volume(rng, height, width, lanes, 12000)
            for rows in {(0, height), (height // 3, height - height // 4), (height - 1, height)}:
                for cols in {(0, width), (width // 2, width)}:
                    for margin in (True, False):
                        args = (cost, luma, table, diagonals, rows, cols, ndisp, subpixel, margin)
                        (two, up_two), (one, up_one) = _choose(*args, 2), _choose(*args, 1)
                        where = f"{height}x{width}x{lanes} rows {rows} cols {cols}"
                        for a, b in zip(two, one, strict=True):
                            np.testing.assert_array_equal(
                                a.view(np.uint8), b.view(np.uint8), err_msg=where
                            )
                        assert (up_one == -9).all()  # one thread: no volume from below
                        assert not (up_two == -9).all()


def test_one_thread_sweep_by_hand():
    # one pixel: every path starts there (L = C), so the total is 8 C (the vertical and
    # the diagonal paths from above and below, the two horizontal ones): totals 40, 16, 72,
    # 56 for costs 5, 2, 9, 7; the least is k = 1: best 1, value 16, disparity dmin + 1 = 4
    # less the parabola's offset (40 - 72) / (2 (40 - 32 + 72)) = -0.2; the rival two or
    # more away is k = 3 (56): margin (56 - 16) / 56
    cost = np.full(LANES, 900, np.int16)
    cost[:4] = (5, 2, 9, 7)
    luma = np.zeros((1, 1), np.int32)
    table = np.full(4081, 50, np.int64)
    down = np.empty_like(cost)
    best, value, candidate, margin = _outputs(1, 1, True)
    sgm_kernels.vertical_pass(cost, luma, 0, 0, 1, 3, table, True, down)
    np.testing.assert_array_equal(down, 3 * cost)
    sgm_kernels.up_final_pass(
        cost, luma, down, 0, 1, 0, 1, 3, 4, 3, table, True, sgm_kernels.SUBPIXEL_PARABOLA,
        best, value, candidate, margin, 0, 0,
    )  # fmt: skip
    assert (best[0, 0], value[0, 0]) == (1, 16)
    assert candidate[0, 0] == np.float32(4 - 0.2)
    assert margin[0, 0] == np.float32((56 - 16) / 56)
