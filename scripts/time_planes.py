"""Time ``sgm`` with and without ``planes``, and the parts of the planes stage.

    NUMBA_NUM_THREADS=1 python scripts/time_planes.py
    NUMBA_NUM_THREADS=1 python scripts/time_planes.py --scenes Piano --plane-params "{...}"

Per scene, the least of ``--repeats`` runs (one process, compiled first), in milliseconds:
``sgm`` and ``planes`` (``dcstereo.match`` without and with ``planes=True``); ``margin``
(what keeping ``sgm``'s confidence margin adds to its run); ``refine`` (the stage,
:func:`dcstereo.refine.planes.refine_planes`, on ``sgm``'s unfilled map), and its parts:
``slic`` (the superpixels of every pass, the shrunk images included), ``fit`` (the planes
of every pass) and ``apply`` (the masks and the planes' values).
"""

import argparse
import ast
import sys
import time
from dataclasses import replace

import numpy as np
from eval_refine import kitti_pairs, middlebury_pairs, sgm_params

import dcstereo
from dcstereo.methods.sgm import _run, colour_channels
from dcstereo.refine import _planes as kernels
from dcstereo.refine import planes
from dcstereo.result import FLAG_BORDER, FLAG_OCCLUDED


def best_ms(run, repeats):
    """Least wall time of ``run()`` over ``repeats`` runs in milliseconds, after one run to
    compile (the least: what the code costs when no other process takes the core)."""
    run()
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        run()
        times.append(1000 * (time.perf_counter() - start))
    return float(np.min(times))


def stage_parts(raw, colour, margin, params, clock):
    """:func:`~dcstereo.refine.planes.refine_planes`' passes, each part's seconds added to
    ``clock`` (a dict): the same calls, timed one by one."""
    tick = time.perf_counter()
    free = (raw.flags & (FLAG_OCCLUDED | FLAG_BORDER)) == 0
    unsure = margin < params.replace_margin
    sure = margin >= params.fit_margin
    scales = planes.pass_scales(params)
    out = np.array(raw.disparity, dtype=np.float32)
    scratch = planes.point_buffers(out.shape)
    labels_full = np.empty(out.shape, dtype=np.int32)
    holes, usable, replaceable = (np.empty(out.shape, dtype=bool) for _ in range(3))
    clock["apply"] += time.perf_counter() - tick
    tick = time.perf_counter()
    small = {scale: planes.shrunk(colour, scale) for scale in set(scales)}
    clock["slic"] += time.perf_counter() - tick
    low, high = raw.params.min_disparity, raw.params.max_disparity
    for step, scale in zip(params.steps, scales, strict=True):
        tick = time.perf_counter()
        labels, nx, ny = planes.coarse_superpixels(
            colour, step, params.compactness, params.slic_iterations, scale,
            small=small[scale], out=labels_full,
        )  # fmt: skip
        clock["slic"] += time.perf_counter() - tick
        tick = time.perf_counter()
        np.isnan(out, out=holes)
        np.greater(sure, holes, out=usable)
        np.logical_or(holes, unsure, out=replaceable)
        replaceable &= free
        clock["apply"] += time.perf_counter() - tick
        tick = time.perf_counter()
        fitted, support = planes.fit_planes(
            out, usable, labels, nx, ny, params.iterations, params.inlier, params.stop,
            params.max_scored, wanted=replaceable, min_support=params.min_support,
            lattice=params.fit_lattice, scratch=scratch,
        )  # fmt: skip
        clock["fit"] += time.perf_counter() - tick
        tick = time.perf_counter()
        used, inliers, size = support[:, 0], support[:, 1], support[:, 2]
        trusted = (used >= 3) & (used >= params.min_support * size)
        trusted &= inliers >= params.min_ratio * np.maximum(used, 1)
        kernels.apply_planes(
            out, replaceable, labels, fitted, trusted, float(params.outlier), float(low),
            float(high), out,
        )  # fmt: skip
        clock["apply"] += time.perf_counter() - tick
    return out


def time_pair(pair, params, repeats):
    """The line of one scene: its times in milliseconds."""
    options = {"max_disparity": pair.max_disparity, "min_disparity": pair.min_disparity}
    sgm = best_ms(lambda: dcstereo.match(pair.left, pair.right, **options), repeats)
    with_planes = best_ms(
        lambda: dcstereo.match(pair.left, pair.right, planes=True, **options), repeats
    )
    raw_params = replace(sgm_params(pair), fill=False)
    bare = best_ms(lambda: _run(pair.left, pair.right, raw_params, False), repeats)
    kept = best_ms(lambda: _run(pair.left, pair.right, raw_params, True), repeats)
    raw, margin = _run(pair.left, pair.right, raw_params, True)
    colour = colour_channels(pair.left, pair.left)[0]
    refine = best_ms(lambda: planes.refine_planes(raw, colour, margin, params), repeats)
    runs = []
    for _ in range(repeats + 1):
        clock = dict.fromkeys(("slic", "fit", "apply"), 0.0)
        stage_parts(raw, colour, margin, params, clock)
        runs.append(clock)
    parts = {k: 1000 * float(np.min([c[k] for c in runs[1:]])) for k in runs[0]}
    height, width = pair.left.shape[:2]
    size = f"{width}x{height}x{pair.max_disparity - pair.min_disparity + 1}"
    return (
        f"{pair.name:22s} {size:14s} {sgm:6.1f} {with_planes:7.1f} {kept - bare:7.1f} "
        f"{refine:7.1f} {parts['slic']:6.1f} {parts['fit']:6.1f} {parts['apply']:6.1f}"
    )


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenes", default="teddy,Piano,motorcycle,kitti2012_000000_10,"
                        "kitti2012_000001_10")  # fmt: skip
    parser.add_argument("--plane-params", default="{}", help="dict of PlaneParams")
    parser.add_argument("--repeats", type=int, default=7)
    args = parser.parse_args(argv)
    names = args.scenes.split(",")
    params = planes.PlaneParams(**ast.literal_eval(args.plane_params))
    pairs = [p for p in middlebury_pairs() + kitti_pairs() if p.name in names]
    print("scene                  size            sgm  planes  margin  refine   slic    fit  apply")
    for pair in pairs:
        print(time_pair(pair, params, args.repeats), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
