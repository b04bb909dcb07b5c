"""Time two checkouts of dcstereo side by side in one process, calls alternating.

    python scripts/ab_speed.py /path/to/other/src --rounds 21
    python scripts/ab_speed.py ../refactor-base/src --methods dc,dsi5 --scenes tsukuba,venus

The package of this checkout is imported as ``dcstereo``; the one under ``OTHER_SRC`` is
copied to ``--workdir`` as ``dcstereo_other`` (once: a later run reuses the copy and the
kernels numba cached beside it) and imported beside it (its relative imports keep it
whole). Each round calls every
(scene, method) of both, in a new random order, one thread; the table gives the best call
of each and the ratio ``this / other``. On a shared machine a loaded minute slows both
alike, which separate processes would not see. The maps of the two are compared too.
"""

import argparse
import importlib
import random
import shutil
import sys
import tempfile
import time
from pathlib import Path

import numba
import numpy as np

SCENES = ("tsukuba", "venus", "teddy", "cones")
METHODS = ("block", "dsi3", "dsi5", "dc")


def load_other(src: Path, folder: Path):
    """Import ``src/dcstereo`` as ``dcstereo_other`` from a copy in ``folder`` (made once)."""
    target = folder / "dcstereo_other"
    if not target.exists():
        shutil.copytree(src / "dcstereo", target, ignore=shutil.ignore_patterns("__pycache__"))
    sys.path.insert(0, str(folder))
    return importlib.import_module("dcstereo_other")


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("other_src", type=Path, help="the other checkout's src folder")
    parser.add_argument("--scenes", default=",".join(SCENES))
    parser.add_argument("--methods", default=",".join(METHODS))
    parser.add_argument("--rounds", type=int, default=21)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument(
        "--workdir",
        type=Path,
        default=Path(tempfile.gettempdir()) / "ab_speed_other",
        help="where the other package is copied (kept for the next run)",
    )
    args = parser.parse_args(argv)
    numba.set_num_threads(1)
    import dcstereo
    from dcstereo.datasets import load_middlebury

    args.workdir.mkdir(parents=True, exist_ok=True)
    other = load_other(args.other_src.resolve(), args.workdir)
    packages = {"this": dcstereo, "other": other}
    scenes = {name: load_middlebury(name) for name in args.scenes.split(",")}
    methods = args.methods.split(",")
    calls = []
    for name, scene in scenes.items():
        for method in methods:
            for label, package in packages.items():
                kwargs = dict(
                    max_disparity=scene.max_disparity,
                    min_disparity=scene.min_disparity,
                    method=method.removesuffix("+bt"),
                )
                if method.endswith("+bt"):
                    kwargs["cost"] = "bt"
                calls.append((name, method, label, package, scene, kwargs))
    # warm-up (compile or load) and the maps compared
    results = {}
    for name, method, label, package, scene, kwargs in calls:
        result = package.match(scene.left, scene.right, **kwargs)
        results[(name, method, label)] = result
    for name in scenes:
        for method in methods:
            a, b = results[(name, method, "this")], results[(name, method, "other")]
            same = a.disparity.tobytes() == b.disparity.tobytes() and np.array_equal(
                a.flags, b.flags
            )
            if not same:
                print(f"maps differ: {name} {method}")
    best = {key[:3]: np.inf for key in calls}
    rng = random.Random(args.seed)
    for _ in range(args.rounds):
        order = list(calls)
        rng.shuffle(order)
        for name, method, label, package, scene, kwargs in order:
            start = time.perf_counter()
            package.match(scene.left, scene.right, **kwargs)
            elapsed = time.perf_counter() - start
            key = (name, method, label)
            best[key] = min(best[key], elapsed)
    print(f"best of {args.rounds} rounds, 1 thread, ms (this / other)")
    print("| scene | method | this | other | this / other |")
    print("|---|---|---:|---:|---:|")
    for name in scenes:
        for method in methods:
            this, that = best[(name, method, "this")], best[(name, method, "other")]
            print(
                f"| {name} | {method} | {this * 1e3:.2f} | {that * 1e3:.2f} | {this / that:.3f} |"
            )
    return 0


if __name__ == "__main__":
    sys.exit(main())
