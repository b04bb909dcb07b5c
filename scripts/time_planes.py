"""Time ``sgm`` with and without ``planes``, and the parts of the planes stage.

    NUMBA_NUM_THREADS=1 python scripts/time_planes.py
    NUMBA_NUM_THREADS=1 python scripts/time_planes.py --scenes Piano --plane-params "{...}"

Per scene, the least of ``--repeats`` runs (one process, compiled first), in milliseconds:
``sgm`` and ``planes`` (``dcstereo.match`` without and with ``planes=True``); ``margin``
(what keeping ``sgm``'s confidence margin adds to its run); ``refine`` (the stage,
:func:`dcstereo.refine.planes.refine_planes`, on ``sgm``'s unfilled map), and its parts:
``slic`` (the superpixels of every pass, the shrunk images included), ``fit`` (the planes
of every pass) and ``apply`` (the planes' values; the masks are the rest of ``refine``).
"""

import argparse
import ast
import contextlib
import sys
import time
from dataclasses import replace

import numpy as np
from eval_refine import kitti_pairs, middlebury_pairs, sgm_params

import dcstereo
from dcstereo.methods.sgm import _run, colour_channels
from dcstereo.refine import _planes as kernels
from dcstereo.refine import planes


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


@contextlib.contextmanager
def timed_parts(clock):
    """Add the seconds of the planes stage's calls to ``clock`` while the block runs.

    The stage's own module-level calls are wrapped, so that :func:`refine_planes` itself
    runs, not a copy of it: ``slic`` (``shrunk``, ``coarse_superpixels``), ``fit``
    (``fit_planes``) and ``apply`` (the ``apply_planes`` kernel); the rest of the stage (its
    masks, its buffers) is ``refine`` less these.
    """
    parts = {
        (planes, "shrunk"): "slic",
        (planes, "coarse_superpixels"): "slic",
        (planes, "fit_planes"): "fit",
        (kernels, "apply_planes"): "apply",
    }
    saved = {key: getattr(*key) for key in parts}

    def timing(function, part):
        def run(*args, **kwargs):
            start = time.perf_counter()
            try:
                return function(*args, **kwargs)
            finally:
                clock[part] += time.perf_counter() - start

        return run

    try:
        for (module, name), part in parts.items():
            setattr(module, name, timing(saved[module, name], part))
        yield clock
    finally:
        for (module, name), function in saved.items():
            setattr(module, name, function)


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
        with timed_parts(dict.fromkeys(("slic", "fit", "apply"), 0.0)) as clock:
            planes.refine_planes(raw, colour, margin, params)
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
