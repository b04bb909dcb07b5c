"""Where dc's and dsi5's time goes inside the band kernel: the stages' cycle counts.

``_band_kernels.match_band_rows`` takes an optional ``clock`` (int64, one row per chunk,
one column per stage of ``_band_kernels.CLOCK_STAGES``): each chunk adds the processor's
cycle counter (``llvm.readcyclecounter``, the TSC on x86) between its stages to its row.
The kernel given no clock is compiled without the counter, so the timed kernel is a
second compiled version of the same code; its stage totals are the sums over the chunks
(with one thread, the call's time less the Python around it).

For each scene (and with ``--synthetic``, ``bench_speed.py``'s synthetic pair, on which
``dc`` runs without the band's cost array when it is wide) and method: one warm-up call,
then ``--repeat`` timed calls through the private entry points ``dcstereo.match`` uses
(``api._match_dc``, ``api._match_dsi``, default parameters); each stage's figure is its
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
from bench_speed import parse_size, synthetic_pair

METHODS = ("dsi5", "dc")


def counter_rate(seconds=0.2):
    """Cycle-counter ticks per second, against ``time.perf_counter``."""
    import numba

    from dcstereo import _band_kernels

    read = numba.njit(lambda: _band_kernels.cycle_counter())
    read()
    t0, c0 = time.perf_counter(), read()
    while time.perf_counter() - t0 < seconds:
        pass
    t1, c1 = time.perf_counter(), read()
    return (c1 - c0) / (t1 - t0)


def stage_times(left, right, min_disparity, max_disparity, method, repeat):
    """``(best call ms, least counts per stage)`` of ``method`` on a pair."""
    from dcstereo import _band_kernels, api
    from dcstereo.params import MatchParams
    from dcstereo.signal import check_image

    left, right = check_image(left, "left"), check_image(right, "right")
    params = MatchParams(max_disparity=max_disparity, min_disparity=min_disparity, method=method)
    run = api._match_dc if method == "dc" else api._match_dsi
    shape = (api._band_chunks(left.shape[0]), len(_band_kernels.CLOCK_STAGES))
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


def table(rows, scenes, stages, rate, markdown):
    """The stage table: a row per (method, stage), a column per scene (ms)."""
    head = ["method", "stage"] + list(scenes)
    lines = []
    for method in METHODS:
        if not any(key[1] == method for key in rows):
            continue
        for index, stage in enumerate(stages):
            values = [rows[(name, method)][1][index] / rate * 1e3 for name in scenes]
            if max(values) == 0:
                continue  # a stage this method does not run
            lines.append([method, stage] + [f"{v:.2f}" for v in values])
        sums = [rows[(name, method)][1].sum() / rate * 1e3 for name in scenes]
        lines.append([method, "sum of stages"] + [f"{v:.2f}" for v in sums])
        lines.append([method, "best call"] + [f"{rows[(n, method)][0]:.2f}" for n in scenes])
    if markdown:
        out = ["| " + " | ".join(head) + " |", "|---|---|" + "---:|" * len(scenes)]
        out += ["| " + " | ".join(line) + " |" for line in lines]
        return "\n".join(out)
    widths = [max(len(str(r[i])) for r in [head] + lines) for i in range(len(head))]

    def text_row(row):
        cells = [str(c).rjust(w) if i > 1 else str(c).ljust(w) for i, (c, w) in
                 enumerate(zip(row, widths, strict=True))]  # fmt: skip
        return "  ".join(cells)

    return "\n".join(text_row(row) for row in [head] + lines)


def parse_args(argv):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenes", help="comma-separated Middlebury scenes (default: all)")
    parser.add_argument("--methods", default=",".join(METHODS), help="dsi5, dc (both)")
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

    from dcstereo import _band_kernels
    from dcstereo.datasets import list_middlebury, load_middlebury

    methods = [m for m in args.methods.split(",") if m]
    unknown = [m for m in methods if m not in METHODS]
    if unknown:
        print(f"error: unknown method(s) {', '.join(unknown)}; choose from dsi5, dc")
        return 2
    if args.repeat < 1:
        print("error: --repeat must be at least 1")
        return 2
    if not 1 <= args.threads <= numba.config.NUMBA_NUM_THREADS:
        print(f"error: --threads must lie between 1 and {numba.config.NUMBA_NUM_THREADS}")
        return 2
    scenes = args.scenes.split(",") if args.scenes else list_middlebury()
    missing = [name for name in scenes if name not in list_middlebury()]
    if missing:
        print(f"error: Middlebury scene(s) not found: {', '.join(missing)}")
        return 2
    if not scenes and not args.synthetic:
        print("error: no Middlebury scenes found (see dcstereo.datasets.middlebury_dir)")
        return 2
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
    print(f"counter: {rate / 1e9:.3f} GHz; threads: {args.threads}; best of {args.repeat}; ms")
    print(table(rows, list(pairs), _band_kernels.CLOCK_STAGES, rate, markdown=False))
    if args.markdown:
        from dcstereo.io import atomic_write

        text = table(rows, list(pairs), _band_kernels.CLOCK_STAGES, rate, markdown=True)
        with atomic_write(args.markdown) as tmp:
            tmp.write_text(text + "\n", encoding="utf-8")
    return 0


if __name__ == "__main__":
    sys.exit(main())
