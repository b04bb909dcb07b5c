"""Sweep the occlusion cost of the DP methods over the Middlebury scenes.

For every scene x method x occlusion cost, run ``dcstereo.match(..., fill=True)`` and score
the dense map with the bad-1.0 rate over the Middlebury v2 ``nonocc`` mask. Prints a markdown
table and writes it (atomically) to ``--out``.

    python scripts/sweep_occlusion.py
    python scripts/sweep_occlusion.py --scenes tsukuba venus --costs 5 10 20 --out /tmp/sweep.md
"""

import argparse
import datetime
import os
import platform
import sys
import time
from pathlib import Path

import numba

import dcstereo
from dcstereo.evaluation.datasets import list_middlebury, load_middlebury, middlebury_dir
from dcstereo.evaluation.metrics import bad_pixel_rate
from dcstereo.io import atomic_write, check_writable

DEFAULT_COSTS = (2.0, 5.0, 10.0, 15.0, 20.0, 30.0, 40.0, 60.0, 80.0)
DEFAULT_METHODS = ("dsi3", "dsi5")
# a measurement, not a page of the documentation (docs/guide/methods.md quotes its means)
DEFAULT_OUT = Path("occlusion_sweep.md")


def machine_line(window: int) -> str:
    """One line: machine, threads, window and date."""
    cpus = os.cpu_count()
    usable = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else cpus
    now = datetime.datetime.now(datetime.UTC).strftime("%Y-%m-%d %H:%M UTC")
    return (
        f"Machine: {platform.platform()} ({platform.machine()}), {cpus} CPUs ({usable} usable), "
        f"numba {numba.__version__} with {numba.get_num_threads()} threads, "
        f"Python {platform.python_version()}; window {window}; fill=True; date {now}."
    )


def write_atomic(path: Path, text: str) -> None:
    """Write ``text`` to ``path`` atomically (``dcstereo.io.atomic_write``), making its folder."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    with atomic_write(path) as tmp:
        tmp.write_text(text, encoding="utf-8")


def output_error(path) -> str | None:
    """Why ``write_atomic`` could not write ``path`` (it makes missing folders), or None."""
    try:
        check_writable(path, make_folders=True)
    except ValueError as err:
        return str(err)
    return None


def sweep(scenes, methods, costs, window):
    """Return ``{(scene, method): [bad-1.0 nonocc per cost]}``."""
    table = {}
    for scene in scenes:
        for method in methods:
            row = []
            for cost in costs:
                result = dcstereo.match(
                    scene.left,
                    scene.right,
                    max_disparity=scene.max_disparity,
                    min_disparity=scene.min_disparity,
                    method=method,
                    window=window,
                    occlusion_cost=cost,
                    fill=True,
                )
                row.append(
                    bad_pixel_rate(
                        result.disparity,
                        scene.disparity,
                        mask=scene.masks["nonocc"],
                        threshold=1.0,
                    )
                )
            table[scene.name, method] = row
            best = min(range(len(costs)), key=row.__getitem__)
            print(
                f"  {scene.name:8s} {method:6s} best {row[best]:6.2f}% at cost {costs[best]:g}",
                file=sys.stderr,
            )
    return table


def markdown(table, scene_names, methods, costs, header, command) -> str:
    """Format the sweep as a markdown document; the best cost of each row in bold."""

    def cells(values):
        best = min(values)
        return [f"**{v:.2f}**" if v == best else f"{v:.2f}" for v in values]

    lines = [
        "# Occlusion-cost sweep: bad-1.0 nonocc (%)",
        "",
        header,
        "",
        "Percentage of Middlebury v2 `nonocc` pixels with |d - d_gt| > 1 for dense maps "
        "(pixels without an estimate filled by `dcstereo.fill_occlusions`); lower is better, "
        "the best cost of each row in bold. Occlusion cost in gray levels of mean absolute "
        "difference per pixel.",
        "",
        f"Command: `{command}`",
        "",
        "| scene | method | " + " | ".join(f"{c:g}" for c in costs) + " | best cost |",
        "| --- | --- | " + " | ".join("---:" for _ in costs) + " | ---: |",
    ]
    for name in scene_names:
        for method in methods:
            values = table[name, method]
            best = costs[values.index(min(values))]
            lines.append(f"| {name} | {method} | " + " | ".join(cells(values)) + f" | {best:g} |")
    if len(scene_names) > 1:
        for method in methods:
            values = [
                sum(table[name, method][i] for name in scene_names) / len(scene_names)
                for i in range(len(costs))
            ]
            best = costs[values.index(min(values))]
            lines.append(f"| *mean* | {method} | " + " | ".join(cells(values)) + f" | {best:g} |")
    return "\n".join(lines) + "\n"


def parse_args(argv):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--scenes", nargs="+", help="Middlebury scene names (default: every scene found)"
    )
    parser.add_argument(
        "--costs",
        nargs="+",
        type=float,
        default=list(DEFAULT_COSTS),
        help="occlusion costs to try (default: %(default)s)",
    )
    parser.add_argument(
        "--methods",
        nargs="+",
        default=list(DEFAULT_METHODS),
        help="dcstereo methods to sweep (default: %(default)s)",
    )
    parser.add_argument("--window", type=int, default=5, help="SAD window (default: 5)")
    parser.add_argument(
        "--out", type=Path, default=DEFAULT_OUT, help="markdown output (default: %(default)s)"
    )
    return parser.parse_args(argv)


def main(argv=None) -> int:
    args = parse_args(argv)
    error = output_error(args.out)
    if error:
        print(f"error: {error}", file=sys.stderr)
        return 2
    names = args.scenes or list_middlebury()
    if not names:
        print(
            f"error: no Middlebury scenes found at {middlebury_dir()}; set DCSTEREO_DATA",
            file=sys.stderr,
        )
        return 2
    try:
        scenes = [load_middlebury(name) for name in names]
    except ValueError as err:
        print(f"error: {err}", file=sys.stderr)
        return 2
    unknown = [m for m in args.methods if m not in dcstereo.METHODS]
    if unknown:
        print(
            f"error: unknown method(s) {', '.join(unknown)}; choose from "
            f"{', '.join(dcstereo.METHODS)}",
            file=sys.stderr,
        )
        return 2
    if any(not cost > 0 for cost in args.costs):
        print(f"error: occlusion costs must be positive, got {args.costs}", file=sys.stderr)
        return 2

    header = machine_line(args.window)
    print(header, file=sys.stderr)
    start = time.perf_counter()
    try:
        table = sweep(scenes, args.methods, args.costs, args.window)
    except ValueError as err:  # a parameter dcstereo.match refuses (--window)
        print(f"error: {err}", file=sys.stderr)
        return 2
    elapsed = time.perf_counter() - start
    command = "python scripts/sweep_occlusion.py " + " ".join(argv or sys.argv[1:])
    text = markdown(
        table, [s.name for s in scenes], args.methods, args.costs, header, command.strip()
    )
    print(text)
    try:
        write_atomic(args.out, text)
    except (OSError, ValueError) as err:
        print(f"error: {err}", file=sys.stderr)
        return 2
    print(f"wrote {args.out} ({elapsed:.1f} s of matching)", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
