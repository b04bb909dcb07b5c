"""Where dc's and dsi5's time goes inside the band kernel: the stages' cycle counts.

``bands.match_band_rows`` takes an optional ``clock`` (int64, one row per chunk,
one column per stage of ``bands.CLOCK_STAGES``): each chunk adds the processor's
cycle counter (``llvm.readcyclecounter``, the TSC on x86) between its stages to its row.
The kernel given no clock is compiled without the counter, so the timed kernel is a
second compiled version of the same code; its stage totals are the sums over the chunks
(with one thread, the call's time less the Python around it).

For each scene (and with ``--synthetic``, ``bench_speed.py``'s synthetic pair, on which
``dc`` runs without the band's cost array when it is wide) and method: one warm-up call,
then ``--repeat`` timed calls through the private entry points ``dcstereo.match`` uses
(``methods.dc._match_dc``, ``methods.dsi._match_dsi``, default parameters); each stage's
figure is its
least over the calls (so the stages may add up to less than the best call). Counts are
turned into milliseconds with the counter's rate, measured against ``time.perf_counter``
for 0.2 s. One thread unless ``--threads``; the per-stage sums then count every thread's
time.

    python benchmarks/bench_stages.py
    python benchmarks/bench_stages.py --scenes tsukuba,venus --methods dc --repeat 31
    python benchmarks/bench_stages.py --markdown stages.md
    python benchmarks/bench_stages.py --scenes tsukuba --synthetic 3000x2000x256 --repeat 2
"""

import argparse
import sys
import time
from pathlib import Path

import numpy as np
from bench_speed import (
    comma_list,
    fail,
    markdown_table,
    output_error,
    parse_size,
    synthetic_pair,
    text_table,
    write_atomic,
)

METHODS = ("dsi5", "dc")


def counter_rate(seconds=0.2):
    """Cycle-counter ticks per second, against ``time.perf_counter``."""
    import numba

    from dcstereo._vector import simd

    read = numba.njit(lambda: simd.cycle_counter())
    read()
    t0, c0 = time.perf_counter(), read()
    while time.perf_counter() - t0 < seconds:
        pass
    t1, c1 = time.perf_counter(), read()
    return (c1 - c0) / (t1 - t0)


def stage_times(left, right, min_disparity, max_disparity, method, repeat):
    """``(best call ms, least counts per stage)`` of ``method`` on a pair."""
    from dcstereo.divide import bands
    from dcstereo.methods import _bands, dc, dsi
    from dcstereo.params import MatchParams
    from dcstereo.signal import check_image

    left, right = check_image(left, "left"), check_image(right, "right")
    params = MatchParams(max_disparity=max_disparity, min_disparity=min_disparity, method=method)
    run = dc._match_dc if method == "dc" else dsi._match_dsi
    shape = (_bands._band_chunks(left.shape[0]), len(bands.CLOCK_STAGES))
    best_call = np.inf
    least = np.full(shape[1], np.iinfo(np.int64).max)
    for i in range(repeat + 1):
        clock = np.zeros(shape, dtype=np.int64)
        start = time.perf_counter()
        run(left, right, params, clock=clock)
        seconds = time.perf_counter() - start
        if i == 0:
            continue  # the warm-up (and, on a first run, the compile)
        best_call = min(best_call, seconds)
        least = np.minimum(least, clock.sum(axis=0))
    return best_call * 1e3, least


def table_rows(rows, names, rate):
    """A row per (method, stage) that the method runs, a value per input (ms)."""
    from dcstereo.divide import bands

    out = []
    for method in METHODS:
        if not any(key[1] == method for key in rows):
            continue
        per_stage = {name: rows[(name, method)][1] / rate * 1e3 for name in names}
        for index, stage in enumerate(bands.CLOCK_STAGES):
            if max(per_stage[name][index] for name in names) == 0:
                continue  # a stage this method does not run
            out.append({"method": method, "stage": stage} | {
                name: per_stage[name][index] for name in names
            })  # fmt: skip
        out.append({"method": method, "stage": "sum of stages"} | {
            name: per_stage[name].sum() for name in names
        })  # fmt: skip
        out.append({"method": method, "stage": "best call"} | {
            name: rows[(name, method)][0] for name in names
        })  # fmt: skip
    return out


def table_columns(names):
    """``bench_speed.py``'s column specs: method, stage, then one per input."""
    return (("method", "method", "s", 6), ("stage", "stage", "s", 13)) + tuple(
        (name, name, ".2f", max(len(name), 7)) for name in names
    )


def parse_args(argv):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenes", help="comma-separated Middlebury scenes (default: all)")
    parser.add_argument(
        "--methods", default=",".join(METHODS), help="comma-separated: dsi5, dc (default: both)"
    )
    parser.add_argument("--repeat", type=int, default=21, help="timed calls per scene (21)")
    parser.add_argument("--threads", type=int, default=1, help="numba threads (1)")
    parser.add_argument(
        "--synthetic",
        type=parse_size,
        metavar="WxHxD",
        help="also bench_speed.py's synthetic pair of this size (e.g. 3000x2000x256)",
    )
    parser.add_argument("--markdown", type=Path, help="also write the table as markdown")
    return parser.parse_args(argv)


def main(argv=None):
    args = parse_args(argv)
    import numba

    from dcstereo.evaluation.datasets import list_middlebury, load_middlebury

    error = output_error(args.markdown)
    if error:
        return fail(error)
    methods = comma_list(args.methods)
    unknown = [m for m in methods if m not in METHODS]
    if unknown or not methods:
        named = f"unknown method(s) {', '.join(unknown)}" if unknown else "no method given"
        return fail(f"--methods: {named}; choose from dsi5, dc")
    if args.repeat < 1:
        return fail("--repeat must be at least 1")
    if not 1 <= args.threads <= numba.config.NUMBA_NUM_THREADS:
        return fail(f"--threads must lie between 1 and {numba.config.NUMBA_NUM_THREADS}")
    present = list_middlebury()
    scenes = comma_list(args.scenes) if args.scenes else present
    missing = [name for name in scenes if name not in present]
    if missing:
        return fail(f"Middlebury scene(s) not found: {', '.join(missing)}")
    if not scenes and not args.synthetic:
        return fail("no Middlebury scenes found (see dcstereo.evaluation.datasets.middlebury_dir)")
    numba.set_num_threads(args.threads)
    rate = counter_rate()
    pairs = {}
    for name in scenes:
        scene = load_middlebury(name)
        pairs[name] = scene.left, scene.right, scene.min_disparity, scene.max_disparity
    if args.synthetic:
        width, height, disparities = args.synthetic
        left, right, _ = synthetic_pair(width, height, disparities)
        pairs["synthetic"] = left, right, 0, disparities - 1
    rows = {}
    for name, pair in pairs.items():
        for method in methods:
            rows[(name, method)] = stage_times(*pair, method, args.repeat)
    lines, columns = table_rows(rows, list(pairs), rate), table_columns(list(pairs))
    print(f"counter: {rate / 1e9:.3f} GHz; threads: {args.threads}; best of {args.repeat}; ms")
    print(text_table(lines, columns))
    if args.markdown:
        try:
            write_atomic(args.markdown, markdown_table(lines, columns) + "\n")
        except (OSError, ValueError) as err:
            return fail(str(err))
    return 0


if __name__ == "__main__":
    sys.exit(main())
