"""The row-by-row drivers of ``dsi3``/``dsi5`` and ``block``: one scanline at a time.

The methods run on the band kernels (:mod:`.bands`) wherever a band's cost array fits;
these drivers run them row by row for the Birchfield-Tomasi cost on images too wide for
it (``api.BAND_ARRAY_BYTES``), with the same results bit for bit, and are the tests'
reference for the band kernels. Rows are the only parallel loop, dealt out in chunks
(``chunk_count``, ``chunk_bounds``: also the chunks of the other row drivers).
"""

import numba as nb
import numpy as np

from dcstereo.costs.window import _row_costs_any
from dcstereo.result import FLAG_BORDER
from dcstereo.scanline.dp import apply_path, path_scratch, scanline_dp


def chunk_count(height: int) -> int:
    """Return how many chunks of rows a row-parallel driver deals out: four per thread.

    Never more than the rows, never fewer than one; ``chunk_bounds`` sizes them.
    """
    return max(1, min(height, 4 * nb.get_num_threads()))


@nb.njit(cache=True)
def chunk_bounds(height, nchunks, c):
    """Return rows ``(y0, y1)`` of chunk ``c`` of ``nchunks`` over ``height`` rows."""
    # sizes differ by at most one, spread evenly: the parallel loop hands each thread an
    # equal run of chunks, so ceil-sized chunks (and a short last one) would leave one
    # thread more work (36 bands in 8 chunks: 20 against 16)
    return c * height // nchunks, (c + 1) * height // nchunks


@nb.njit(parallel=True, cache=True)
def match_dsi_rows(left_p, right_p, dsi, bt, step_costs, nchunks, out):
    """Run the whole-scanline DP on every row; rows are the only parallel loop.

    ``dsi`` (``records.Dsi``): the disparities and the window; ``bt``: the
    Birchfield-Tomasi cost (``row_costs_bt``) instead of the SAD of eq. 4; ``step_costs``
    (``records.StepCosts``): the DP's; ``out`` (``records.Outputs``): ``disparity``,
    ``flags`` and ``total`` are written.
    """
    dmin, ndisp, radius = dsi
    disp, flags, total = out.disparity, out.flags, out.total
    height, width = disp.shape
    for c in nb.prange(nchunks):
        y0, y1 = chunk_bounds(height, nchunks, c)
        cost = np.empty((width, ndisp), dtype=np.float64)
        vcol = np.empty((width, ndisp), dtype=np.int32)
        path = path_scratch(width, ndisp)
        for y in range(y0, y1):
            _row_costs_any(left_p, right_p, y, dmin, ndisp, radius, vcol, cost, y > y0, bt)
            for x in range(width):
                disp[y, x] = np.nan
                flags[y, x] = FLAG_BORDER
            last = width - 1
            n, t = scanline_dp(cost, dmin, step_costs, 0, last, 0, last, False, False, path)
            apply_path(path, n, dmin, disp[y], flags[y])
            total[y] = t


@nb.njit(parallel=True, cache=True)
def match_block_rows(left_p, right_p, dsi, bt, nchunks, out):
    """Winner-take-all block matching: the disparity of least window cost per pixel.

    ``bt``: the Birchfield-Tomasi cost (``row_costs_bt``) instead of the SAD of eq. 4; the
    other arguments as ``match_dsi_rows``' (``disparity``, ``flags``, ``total`` written).
    """
    dmin, ndisp, radius = dsi
    disp, flags, total = out.disparity, out.flags, out.total
    height, width = disp.shape
    for c in nb.prange(nchunks):
        y0, y1 = chunk_bounds(height, nchunks, c)
        cost = np.empty((width, ndisp), dtype=np.float64)
        vcol = np.empty((width, ndisp), dtype=np.int32)
        for y in range(y0, y1):
            _row_costs_any(left_p, right_p, y, dmin, ndisp, radius, vcol, cost, y > y0, bt)
            t = 0.0
            for x in range(width):
                best = np.inf
                best_k = -1
                for k in range(ndisp):
                    if cost[x, k] < best:
                        best = cost[x, k]
                        best_k = k
                if best_k < 0:
                    disp[y, x] = np.nan
                    flags[y, x] = FLAG_BORDER
                else:
                    disp[y, x] = dmin + best_k
                    flags[y, x] = 0
                    t += best
            total[y] = t
