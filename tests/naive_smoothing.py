"""The slow twin of ``dcstereo.costs.smoothing``: the 2-D sum written out, pixel by pixel."""

import numpy as np


def smooth(signal: np.ndarray, weights: np.ndarray, bits: int) -> np.ndarray:
    """``signal`` (int, ``(H, W)``) smoothed by the integer weights ``weights`` each way.

    Each output pixel is ``sum_ij w_i w_j s[clip(y + i - r), clip(x + j - r)]``, the edges
    repeated, divided by ``2 ** (2 * bits)`` and rounded half up: the definition, one
    pixel and one term at a time, in Python integers.
    """
    height, width = signal.shape
    radius = len(weights) // 2
    out = np.empty((height, width), dtype=np.int64)
    for y in range(height):
        for x in range(width):
            total = 0
            for i, wi in enumerate(weights):
                yy = min(max(y + i - radius, 0), height - 1)
                for j, wj in enumerate(weights):
                    xx = min(max(x + j - radius, 0), width - 1)
                    total += int(wi) * int(wj) * int(signal[yy, xx])
            out[y, x] = (total + (1 << (2 * bits - 1))) >> (2 * bits)
    return out
