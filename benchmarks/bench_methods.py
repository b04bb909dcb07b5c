"""Speed and accuracy of the dcstereo methods against OpenCV StereoSGBM on Middlebury.

For each scene and method: one warm-up call (numba compiles on the first), then the best of
``--repeat`` timed calls (``time.perf_counter``) of the matcher alone. The score is the
bad-1.0 rate over the Middlebury v2 ``nonocc`` mask of the *dense* map: pixels without an
estimate are filled with ``dcstereo.fill_occlusions`` first (outside the timing), so every
method is scored on every pixel. ``density`` is the share of ``nonocc`` pixels the matcher
itself gave an estimate.

Throughput is ``H * W * D / 1e6 / seconds`` (millions of disparity evaluations per second)
with ``D`` the number of disparities the method searched (SGBM: rounded up to 16).

    python benchmarks/bench_methods.py
    python benchmarks/bench_methods.py --scenes tsukuba --methods dsi5 --threads 1 --json out.json
"""

import argparse
import datetime
import json
import os
import platform
import sys
import tempfile
import time
from pathlib import Path

import numba
import numpy as np

import dcstereo
from dcstereo.datasets import list_middlebury, load_middlebury, middlebury_dir
from dcstereo.metrics import bad_pixel_rate, density

DEFAULT_METHODS = ("block", "dsi3", "dsi5")
SGBM = "sgbm (opencv)"


def cpu_model() -> str:
    """CPU model name from /proc/cpuinfo, else what platform knows."""
    try:
        with open("/proc/cpuinfo", encoding="utf-8") as stream:
            for line in stream:
                if line.startswith("model name"):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine()


def machine_info(cv2) -> dict:
    """Where and with what the benchmark ran."""
    usable = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    return {
        "date": datetime.datetime.now(datetime.UTC).isoformat(timespec="seconds"),
        "platform": platform.platform(),
        "cpu": cpu_model(),
        "cpu_count": os.cpu_count(),
        "cpus_usable": usable,
        "python": platform.python_version(),
        "numpy": np.__version__,
        "numba": numba.__version__,
        "numba_threads": numba.get_num_threads(),
        "dcstereo": dcstereo.__version__,
        "opencv": cv2.__version__ if cv2 else None,
        "opencv_threads": cv2.getNumThreads() if cv2 else None,
    }


def best_time(call, repeat):
    """One warm-up call, then the best of ``repeat`` timed calls; return (output, seconds)."""
    output = call()
    best = float("inf")
    for _ in range(repeat):
        start = time.perf_counter()
        output = call()
        best = min(best, time.perf_counter() - start)
    return output, best


def sgbm_matcher(cv2, scene):
    """StereoSGBM with the usual settings for a 5x5 block; returns (call, disparities)."""
    channels = scene.left.shape[2] if scene.left.ndim == 3 else 1
    num_disparities = -(-(scene.max_disparity - scene.min_disparity + 1) // 16) * 16
    matcher = cv2.StereoSGBM_create(
        minDisparity=scene.min_disparity,
        numDisparities=num_disparities,
        blockSize=5,
        P1=8 * channels * 5**2,
        P2=32 * channels * 5**2,
        disp12MaxDiff=1,
        uniquenessRatio=10,
        speckleWindowSize=0,
        speckleRange=0,
        mode=cv2.STEREO_SGBM_MODE_SGBM,
    )
    left = np.ascontiguousarray(scene.left)
    right = np.ascontiguousarray(scene.right)

    def call():
        raw = matcher.compute(left, right)  # int16, 1/16 pixel; invalid below minDisparity
        disparity = raw.astype(np.float32) / 16.0
        disparity[raw < 16 * scene.min_disparity] = np.nan
        return disparity

    return call, num_disparities


def score(scene, disparity, seconds, method, num_disparities):
    """One row of the table."""
    nonocc = scene.masks["nonocc"]
    filled, _ = dcstereo.fill_occlusions(disparity)
    height, width = disparity.shape
    return {
        "scene": scene.name,
        "method": method,
        "disparities": int(num_disparities),
        "bad_1_nonocc_dense": bad_pixel_rate(filled, scene.disparity, mask=nonocc),
        "density_nonocc": density(disparity, scene.disparity, mask=nonocc),
        "ms": 1e3 * seconds,
        "mde_per_s": height * width * num_disparities / 1e6 / seconds,
    }


def bench_scene(scene, methods, repeat, window, cv2):
    """Rows for one scene: the dcstereo methods, then SGBM; time ratios to SGBM filled in."""
    rows = []
    for method in methods:

        def call(method=method):
            return dcstereo.match(
                scene.left,
                scene.right,
                max_disparity=scene.max_disparity,
                min_disparity=scene.min_disparity,
                method=method,
                window=window,
            ).disparity

        disparity, seconds = best_time(call, repeat)
        num = scene.max_disparity - scene.min_disparity + 1
        rows.append(score(scene, disparity, seconds, method, num))
    if cv2 is not None:
        call, num = sgbm_matcher(cv2, scene)
        disparity, seconds = best_time(call, repeat)
        rows.append(score(scene, disparity, seconds, SGBM, num))
        for row in rows:
            row["time_vs_sgbm"] = row["ms"] / rows[-1]["ms"]
    return rows


TABLE_HEADER = (
    f"{'scene':9s} {'method':14s} {'D':>3s} {'bad-1.0 nonocc %':>16s} {'density %':>9s} "
    f"{'ms':>8s} {'M disp/s':>9s} {'x SGBM':>7s}"
)


def format_row(row) -> str:
    """One line of the table, aligned with :data:`TABLE_HEADER`."""
    ratio = row.get("time_vs_sgbm")
    return (
        f"{row['scene']:9s} {row['method']:14s} {row['disparities']:3d} "
        f"{row['bad_1_nonocc_dense']:16.2f} {row['density_nonocc']:9.1f} "
        f"{row['ms']:8.1f} {row['mde_per_s']:9.1f} "
        + (f"{ratio:7.2f}" if ratio is not None else f"{'-':>7s}")
    )


def write_json_atomic(path: Path, payload) -> None:
    """Write ``payload`` as JSON through a temporary file in the same folder."""
    path.parent.mkdir(parents=True, exist_ok=True)
    handle, temp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    try:
        with os.fdopen(handle, "w", encoding="utf-8") as stream:
            json.dump(payload, stream, indent=2)
            stream.write("\n")
        os.replace(temp, path)
    except BaseException:
        Path(temp).unlink(missing_ok=True)
        raise


def parse_args(argv):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--scenes", nargs="+", help="Middlebury scene names (default: every scene found)"
    )
    parser.add_argument(
        "--methods",
        nargs="+",
        default=list(DEFAULT_METHODS),
        help="dcstereo methods (default: %(default)s)",
    )
    parser.add_argument("--repeat", type=int, default=3, help="timed calls, best kept (3)")
    parser.add_argument("--window", type=int, default=5, help="dcstereo SAD window (5)")
    parser.add_argument("--threads", type=int, help="numba and OpenCV threads (default: all)")
    parser.add_argument("--no-opencv", action="store_true", help="leave out StereoSGBM")
    parser.add_argument("--json", type=Path, help="also write the results to this JSON file")
    return parser.parse_args(argv)


def main(argv=None) -> int:
    args = parse_args(argv)

    def fail(message):
        print(f"error: {message}", file=sys.stderr)
        return 2

    if args.repeat < 1:
        return fail(f"--repeat must be at least 1, got {args.repeat}")
    unknown = [m for m in args.methods if m not in dcstereo.METHODS]
    if unknown:
        return fail(
            f"unknown method(s) {', '.join(unknown)}; choose from {', '.join(dcstereo.METHODS)}"
        )
    cv2 = None
    if not args.no_opencv:
        try:
            import cv2
        except ImportError:
            print(
                "OpenCV (cv2) is not installed: StereoSGBM is left out "
                '(pip install "dcstereo[opencv]")'
            )
    if args.threads is not None:
        limit = numba.config.NUMBA_NUM_THREADS
        if not 1 <= args.threads <= limit:
            return fail(f"--threads must be between 1 and {limit}, got {args.threads}")
        numba.set_num_threads(args.threads)
        if cv2 is not None:
            cv2.setNumThreads(args.threads)
    names = args.scenes or list_middlebury()
    if not names:
        return fail(f"no Middlebury scenes found at {middlebury_dir()}; set DCSTEREO_DATA")
    try:
        scenes = [load_middlebury(name) for name in names]
    except ValueError as err:
        return fail(str(err))

    machine = machine_info(cv2)
    print(
        f"{machine['date']}  {machine['platform']}\n"
        f"CPU: {machine['cpu']}, {machine['cpu_count']} CPUs ({machine['cpus_usable']} usable); "
        f"numba {machine['numba']} with {machine['numba_threads']} threads; "
        + (
            f"OpenCV {machine['opencv']} with {machine['opencv_threads']} threads; "
            if cv2 is not None
            else "OpenCV not used; "
        )
        + f"numpy {machine['numpy']}; Python {machine['python']}"
    )
    print(
        f"window {args.window}; best of {args.repeat} after one warm-up; "
        "bad-1.0 over nonocc of the dense (filled) map; ms = matcher alone\n"
    )
    print(TABLE_HEADER)
    print("-" * len(TABLE_HEADER), flush=True)
    rows = []
    for scene in scenes:
        scene_rows = bench_scene(scene, args.methods, args.repeat, args.window, cv2)
        rows.extend(scene_rows)
        print("\n".join(format_row(row) for row in scene_rows), flush=True)
    if args.json:
        settings = {"window": args.window, "repeat": args.repeat, "threads": args.threads}
        write_json_atomic(args.json, {"machine": machine, "settings": settings, "results": rows})
        print(f"\nwrote {args.json}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
