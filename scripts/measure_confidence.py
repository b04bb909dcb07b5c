"""Measure how well dcstereo.refine.confidence ranks the pixels of the Middlebury scenes.

    python scripts/measure_confidence.py [--data ../shared/data/middlebury]

For each scene and method (the sparse maps: occlusions left empty), the pixels of the
nonocc mask that have an estimate are sorted by confidence, surest first, and bad-1.0 is
measured over the surest 25 %, 50 %, 75 % and all of them (a sparsification curve: a
ranking that knew nothing would give the last column's value at every density). Prints a
markdown table; the README's "Confidence" quotes it.
"""

import sys
import time

import numpy as np
from measure_subpixel import middlebury_scenes

import dcstereo
from dcstereo.refine.confidence import confidence

METHODS = ("dc", "dsi5")
KEPT = (0.25, 0.5, 0.75, 1.0)


def main(argv=None):
    scenes = middlebury_scenes(argv, __doc__.splitlines()[0])
    if scenes is None:
        return 2
    header = " | ".join(f"bad-1.0, surest {round(100 * k)} %" for k in KEPT)
    print(f"| scene | method | {header} | confidence (ms) |")
    print("| --- | --- |" + " ---: |" * (len(KEPT) + 1))
    for scene in scenes:
        for method in METHODS:
            result = dcstereo.match(
                scene.left, scene.right, max_disparity=scene.max_disparity,
                min_disparity=scene.min_disparity, method=method,
            )  # fmt: skip
            start = time.perf_counter()
            sure = confidence(result, scene.left, scene.right)
            seconds = time.perf_counter() - start
            scored = scene.masks["nonocc"] & np.isfinite(scene.disparity)
            scored &= np.isfinite(result.disparity)
            bad = np.abs(result.disparity - scene.disparity)[scored] > 1.0
            order = np.argsort(-np.nan_to_num(sure[scored], nan=-2.0), kind="stable")
            rates = [100 * bad[order[: max(1, round(k * len(order)))]].mean() for k in KEPT]
            cells = " | ".join(f"{r:.2f}" for r in rates)
            print(f"| {scene.name} | {method} | {cells} | {seconds * 1000:.1f} |", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
