"""The sparse census transform: a census whose window samples every ``step``-th pixel.

A ``rows x cols`` census with ``step`` 2 compares the centre with the pixels at offsets
``(step * i, step * j)``: it sees a window ``step`` times as wide for the same bits (Zabih
and Woodfill's census; the sparse pattern as in Hirschmueller's and Zinner's SGM
implementations). ``step`` 1 is :func:`dcstereo.costs.census.census_transform` exactly.
"""

import numba as nb


@nb.njit(cache=True, parallel=True)
def census_sparse(padded, rows, cols, step, out):
    """Write the sparse census codes into ``out`` (``(H, W)``, uint32 or uint64).

    ``padded`` is the intensity padded by ``step * (rows // 2)`` rows and ``step * (cols //
    2)`` columns on each side, repeating its edges. Bit order as ``census_transform``'s:
    the window in raster order, the centre left out, the first pixel in the highest bit; a
    bit is 1 where that pixel is darker than the centre.
    """
    height, width = out.shape
    ry, rx = step * (rows // 2), step * (cols // 2)
    for y in nb.prange(height):
        code = out[y]
        centre = padded[y + ry, rx : rx + width]
        for x in range(width):
            code[x] = 0
        for i in range(rows):
            for j in range(cols):
                if i == rows // 2 and j == cols // 2:
                    continue
                other = padded[y + step * i, step * j : step * j + width]
                for x in range(width):
                    code[x] = (code[x] << 1) | (other[x] < centre[x])
