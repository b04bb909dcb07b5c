"""Time ``sgm``'s vertical passes: the fused two-task passes against the split ones.

    taskset -c 1 python scripts/time_vertical_passes.py --bands 1,12,32
    python scripts/time_vertical_passes.py --threads 2,4,6,8,16   # on a machine with cores

The volumes are those ``dcstereo.match`` builds for each scene (its defaults, the scene's
disparity range). Per scene and paths, the least of ``--repeats`` runs in milliseconds,
the contenders' calls alternating on the same volumes (compiled first), and each split
run's volumes checked equal to the fused ones:

* ``--bands``: one thread, :func:`~dcstereo.aggregate.sgm.vertical_passes` against
  :func:`~dcstereo.aggregate.sgm.split_passes` with each band count (the split's extra work);
* ``--threads``: at each thread count ``n`` (at most ``NUMBA_NUM_THREADS``), the fused
  passes against the split ones with ``split_bands(width, n)`` bands (where the switch,
  ``SPLIT_THREADS``, belongs).
"""

import argparse
import time

import numba
import numpy as np

import dcstereo
from dcstereo.aggregate import sgm as kernels
from dcstereo.evaluation.datasets import default_data_dir, load_scene


def captured_volume(scene, paths):
    """The arguments ``match`` passes to the vertical passes for ``scene``.

    Taken from ``paths_and_choices``, which every thread count runs (on one thread the
    passes side by side never do: the sweep up replaces them).
    """
    saved, captured = kernels.paths_and_choices, {}

    def grab(cost, luma, *rest):
        p1, table, diagonals = rest[8:11]  # after down, up, y0, y1, x0, x1, dmin, ndisp
        captured["args"] = (cost.copy(), luma.copy(), p1, table.copy(), diagonals)
        saved(cost, luma, *rest)

    kernels.paths_and_choices = grab
    try:
        dcstereo.match(scene.left, scene.right, max_disparity=scene.max_disparity, paths=paths)
    finally:
        kernels.paths_and_choices = saved
    return captured["args"]


def best_ms(runs, repeats):
    """Least wall time of each of ``runs`` (name: function) in ms, their calls alternating."""
    for run in runs.values():
        run()  # compile
    best = dict.fromkeys(runs, np.inf)
    for _ in range(repeats):
        for name, run in runs.items():
            start = time.perf_counter()
            run()
            best[name] = min(best[name], 1000 * (time.perf_counter() - start))
    return best


def contenders(volume, threads, band_counts):
    """The fused passes and the split ones with each band count, and their output volumes."""
    cost, luma, p1, table, diagonals = volume
    fused = (np.empty_like(cost), np.empty_like(cost))
    runs = {
        "fused": lambda: kernels.vertical_passes(cost, luma, p1, table, diagonals, *fused, threads)
    }
    outputs = {}
    for bands in band_counts:
        out = (np.empty_like(cost), np.empty_like(cost))
        outputs[bands] = out
        runs[f"split {bands}"] = lambda b=bands, o=out: kernels.split_passes(
            cost, luma, p1, table, diagonals, *o, threads, b
        )
    return runs, fused, outputs


def main():
    """Parse the options and print one line per scene, paths and thread count."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--scenes", default="teddy,cones,Piano", help="Middlebury scene folders")
    parser.add_argument("--paths", default="8,4", help="paths, comma-separated")
    parser.add_argument("--bands", default="", help="one thread: these band counts")
    parser.add_argument("--threads", default="", help="these thread counts, split_bands bands")
    parser.add_argument("--repeats", type=int, default=9)
    args = parser.parse_args()
    most = numba.config.NUMBA_NUM_THREADS
    if any(int(t) > most for t in args.threads.split(",") if t):
        parser.error(f"--threads {args.threads}: at most NUMBA_NUM_THREADS ({most}) threads")
    root = default_data_dir() / "middlebury"
    for name in args.scenes.split(","):
        scene = load_scene(root / name)
        for paths in (int(p) for p in args.paths.split(",")):
            numba.set_num_threads(numba.config.NUMBA_NUM_THREADS)
            volume = captured_volume(scene, paths)
            height, width = volume[1].shape
            lanes = volume[0].size // (height * width)
            plans = []
            if args.bands:
                plans.append((1, [int(b) for b in args.bands.split(",")]))
            for threads in (int(t) for t in args.threads.split(",") if t):
                plans.append((threads, [kernels.split_bands(width, threads)]))
            for threads, band_counts in plans:
                numba.set_num_threads(threads)
                runs, fused, outputs = contenders(volume, threads, band_counts)
                best = best_ms(runs, args.repeats)
                for out in outputs.values():
                    assert all((a == b).all() for a, b in zip(out, fused, strict=True))
                cells = ", ".join(
                    f"{key} {ms:.1f} ({ms / best['fused']:.2f}x)" for key, ms in best.items()
                )
                print(f"{name} {width}x{height}x{lanes}, {paths} paths, {threads} threads: {cells}")


if __name__ == "__main__":
    main()
