"""Time ``sgm`` with and without ``planes`` on a few scenes (one process, warmed up).

    NUMBA_NUM_THREADS=1 python scripts/time_planes.py

The median of three runs of ``dcstereo.match`` per scene and setting, in milliseconds.
"""

import sys
import time

import numpy as np
from eval_refine import kitti_pairs, middlebury_pairs

import dcstereo


def main():
    pairs = [p for p in middlebury_pairs() if p.name in ("teddy", "Piano", "motorcycle")]
    pairs += kitti_pairs()[:2]
    for pair in pairs:
        row = []
        for planes in (False, True):

            def run(pair=pair, planes=planes):
                return dcstereo.match(pair.left, pair.right, max_disparity=pair.max_disparity,
                                      min_disparity=pair.min_disparity, planes=planes)  # fmt: skip

            run()
            times = []
            for _ in range(3):
                start = time.perf_counter()
                run()
                times.append(1000 * (time.perf_counter() - start))
            row.append(float(np.median(times)))
        print(
            f"{pair.name:22s} {pair.left.shape[1]}x{pair.left.shape[0]}x"
            f"{pair.max_disparity - pair.min_disparity + 1}  sgm {row[0]:6.0f} ms  "
            f"planes {row[1]:6.0f} ms  (+{100 * (row[1] / row[0] - 1):.0f} %)",
            flush=True,
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
