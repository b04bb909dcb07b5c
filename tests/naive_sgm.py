"""Slow, obviously correct twins of the ``sgm`` kernels (census, costs, paths, checks).

Plain Python and numpy, one definition at a time, on small images; the tests hold the
compiled pipeline to these bit for bit.
"""

import numpy as np

#: The eight path directions (dx, dy): a path in direction (dx, dy) reaches (x, y) from
#: (x - dx, y - dy). The first four are the four-path set.
DIRECTIONS = ((1, 0), (-1, 0), (0, 1), (0, -1), (1, 1), (-1, 1), (1, -1), (-1, -1))


def census(signal, rows, cols):
    """Census codes: bit per window pixel (raster order, centre skipped), 1 where darker."""
    height, width = signal.shape
    out = np.zeros((height, width), dtype=np.uint64)
    for y in range(height):
        for x in range(width):
            bits = []
            for dy in range(-(rows // 2), rows // 2 + 1):
                for dx in range(-(cols // 2), cols // 2 + 1):
                    if dy == 0 and dx == 0:
                        continue
                    yy = min(max(y + dy, 0), height - 1)
                    xx = min(max(x + dx, 0), width - 1)
                    bits.append(1 if signal[yy, xx] < signal[y, x] else 0)
            code = 0
            for bit in bits:
                code = code * 2 + bit
            out[y, x] = code
    return out


def pixel_costs(codes_l, codes_r, colour_l, colour_r, dmin, ndisp, bit_cost, ad_max):
    """Per-pixel costs ``(H, W, ndisp)`` in thirds of a unit; the right pixel clamped.

    A census bit costs ``bit_cost`` units, the mean absolute difference of the channels
    one unit per gray level, truncated at ``ad_max`` units.
    """
    height, width = codes_l.shape
    channels = colour_l.shape[0]
    out = np.zeros((height, width, ndisp), dtype=np.int64)
    for y in range(height):
        for x in range(width):
            for k in range(ndisp):
                xr = min(max(x - dmin - k, 0), width - 1)
                bits = bin(int(codes_l[y, x]) ^ int(codes_r[y, xr])).count("1")
                cost = 3 * bit_cost * bits
                if ad_max > 0:
                    ad = sum(
                        abs(int(colour_l[c, y, x]) - int(colour_r[c, y, xr]))
                        for c in range(channels)
                    )
                    cost += min(ad * 3 // channels, 3 * ad_max)
                out[y, x, k] = cost
    return out


def box_mean(costs, box):
    """The floor of the mean over the ``box x box`` square (edges repeated), per disparity."""
    height, width, _ = costs.shape
    radius = box // 2
    out = np.zeros_like(costs)
    for y in range(height):
        for x in range(width):
            total = 0
            for dy in range(-radius, radius + 1):
                for dx in range(-radius, radius + 1):
                    total = (
                        total
                        + costs[min(max(y + dy, 0), height - 1), min(max(x + dx, 0), width - 1)]
                    )
            out[y, x] = total // (box * box)
    return out


def path_values(costs, luma, direction, p1, p2_table):
    """``L_r(p, d)`` of Hirschmueller's eq. 13 for one direction, every pixel."""
    height, width, ndisp = costs.shape
    dx, dy = direction
    values = np.zeros_like(costs)
    order_y = range(height) if dy >= 0 else range(height - 1, -1, -1)
    order_x = range(width) if dx >= 0 else range(width - 1, -1, -1)
    for y in order_y:
        for x in order_x:
            qx, qy = x - dx, y - dy
            if not (0 <= qx < width and 0 <= qy < height):
                values[y, x] = costs[y, x]
                continue
            prev = values[qy, qx]
            least = prev.min()
            p2 = p2_table[abs(int(luma[y, x]) - int(luma[qy, qx]))]
            for k in range(ndisp):
                options = [prev[k], least + p2]
                if k > 0:
                    options.append(prev[k - 1] + p1)
                if k < ndisp - 1:
                    options.append(prev[k + 1] + p1)
                values[y, x, k] = costs[y, x, k] + min(options) - least
    return values


def aggregate(costs, luma, p1, p2_table, paths):
    """The sum of the path values over ``paths`` (4 or 8) directions."""
    return sum(path_values(costs, luma, d, p1, p2_table) for d in DIRECTIONS[:paths])


def choose(sums, dmin, tolerance, subpixel):
    """Winner-take-all, the left-right check and the sub-pixel fit of ``final_pass``.

    Returns ``(disparity, flags)`` with flags 1 occluded, 2 border, 16 mismatch.
    """
    height, width, ndisp = sums.shape
    disparity = np.full((height, width), np.nan, dtype=np.float32)
    flags = np.zeros((height, width), dtype=np.uint8)
    for y in range(height):
        best = [int(np.argmin(sums[y, x])) for x in range(width)]  # first least
        right_best, right_d = {}, {}
        for x in range(width):
            value = sums[y, x, best[x]]
            xr = x - dmin - best[x]
            if 0 <= xr < width and (xr not in right_best or value < right_best[xr]):
                right_best[xr] = value
                right_d[xr] = dmin + best[x]
        for x in range(width):
            k = best[x]
            d = dmin + k
            xr = x - d
            if not 0 <= xr < width:
                flags[y, x] = 2
            elif tolerance is not None and abs(right_d[xr] - d) > tolerance:
                flags[y, x] = 1 if right_d[xr] > d else 16
            else:
                offset = 0.0
                if subpixel and 0 < k < ndisp - 1:
                    a, b, c = (float(v) for v in sums[y, x, k - 1 : k + 2])
                    den = a - 2 * b + c if subpixel == "parabola" else max(a, c) - b
                    offset = (a - c) / (2 * den) if den > 0 else 0.0
                disparity[y, x] = np.float32(d + offset)
    return disparity, flags


def fill(disparity, mismatched, colour):
    """The fill of ``consistency.fill_inconsistent``: mismatches from their most similar
    neighbour along 8 directions, everything else (and a mismatch with none) from the
    background of its row; only estimates are read."""
    height, width = disparity.shape
    directions = ((1, 0), (-1, 0), (0, 1), (0, -1), (1, 1), (-1, -1), (1, -1), (-1, 1))
    out = disparity.copy()
    for y in range(height):
        for x in range(width):
            if not np.isnan(disparity[y, x]):
                continue
            value = np.nan
            if mismatched[y, x]:
                best = None
                for dx, dy in directions:
                    xx, yy = x + dx, y + dy
                    while 0 <= xx < width and 0 <= yy < height and np.isnan(disparity[yy, xx]):
                        xx, yy = xx + dx, yy + dy
                    if 0 <= xx < width and 0 <= yy < height:
                        distance = int(
                            np.abs(colour[:, y, x].astype(int) - colour[:, yy, xx]).sum()
                        )
                        if best is None or distance < best:
                            best, value = distance, disparity[yy, xx]
            if np.isnan(value):
                row = disparity[y]
                left = [v for v in row[:x] if not np.isnan(v)]
                right = [v for v in row[x + 1 :] if not np.isnan(v)]
                sides = ([left[-1]] if left else []) + ([right[0]] if right else [])
                value = min(sides) if sides else np.nan
            out[y, x] = value
    return out
