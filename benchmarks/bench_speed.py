"""Speed and memory of the dcstereo methods against OpenCV StereoBM and StereoSGBM (issue 6).

Every configuration (input, method, thread count) runs in a fresh Python process, started as
``python bench_speed.py --one SPEC``, on the same inputs:

* the Middlebury development scenes (``dcstereo.evaluation.datasets.load_middlebury``), and
* a synthetic ``3000 x 2000`` pair (width x height) searched over 256 disparities: a seeded
  random texture, smoothed with a 3x3 binomial filter so it is matchable, warped by a known
  disparity field (a slanted plane plus a raised rectangle, disparities in 0..255) with
  linear interpolation. It is made once by the parent and saved to a temporary ``.npz``.

In the child: imports, thread count (``numba.set_num_threads`` and ``cv2.setNumThreads``),
inputs; one call on a 32-row strip of the pair (numba compiles or loads its code); then the
resident set size is read (``base``) and the peak RSS counter is reset
(``/proc/self/clear_refs``); then one full-size warm-up call (left out for the large pair
by default, whose code is already warm from the strip) and the best of ``--repeat`` timed
calls (``time.perf_counter``; ``--repeat-large`` for the large pair).

Columns: ``ms`` best call; ``Mde/s`` = ``H * W * D / 1e6 / s``, million disparity
evaluations per second, ``D`` the disparities searched (OpenCV: rounded up to a multiple
of 16, what it really searched); ``base MB`` RSS before the measured calls (interpreter,
libraries, inputs, compiled code); ``peak MB`` the child's whole-life peak RSS;
``method MB`` the peak RSS during the measured calls minus ``base``: the method's own
working memory. Peaks come from ``VmHWM`` in ``/proc/self/status``, read before the reset
and at the end, because on Linux ``ru_maxrss`` of a freshly exec'd child starts at its
parent's peak (the kernel carries it over through fork and exec), which here is the
parent that made the large pair; ``ru_maxrss`` at the end is still kept in the JSON
(``ru_maxrss_mb``), and it is what the table shows where ``/proc`` is missing;
``x SGBM`` time over OpenCV SGBM's at the same thread count (below 1 = faster).

dcstereo methods run with their defaults (``sgm`` the default method, the whole pipeline:
costs, aggregation, left-right check, fill, median, sub-pixel fit); OpenCV runs through
``dcstereo.evaluation.run_method``, as in the results (``docs/RESULTS.md``): SGBM in
``MODE_SGBM`` (``opencv-sgbm``) and ``MODE_HH`` (``opencv-hh``, eight paths) on the colour
images when the pair is colour (``P1 = 8 * 3 * 25``, ``P2 = 32 * 3 * 25``; on gray ``cn =
1``), 5x5 block, uniqueness 10, ``disp12MaxDiff = 1``, speckle filter 100 px / 2, and BM
on the luma: both sides include the conversion of the images and of the result to float32
with NaN holes.

With ``--rounds N``, the whole fresh-process sweep runs ``N`` times, the rounds one after
the other, and each row is the fastest of its ``N`` processes (the memory columns are that
process's): a row that met another tenant's load in one round gets another chance minutes
later. Two-thread rows need it most: one busy vCPU of two stalls every parallel region.

With ``--same-range``, every method searches OpenCV's disparity range: each input's range
with its count rounded up to a multiple of 16 (OpenCV requires it). By default each input
keeps its own range, and OpenCV, which then searches more disparities than the others, is
credited with them in ``Mde/s``; the per-pixel work that does not grow with ``D`` (the
signal, ``dc``'s feature tests, the backtrack) then weighs more on the others' side.

With ``--interleave N``, each Middlebury scene is also timed in one process per thread
count, all methods alternating call by call, best of ``N`` rounds: on a shared machine a
loaded minute shifts whole fresh-process rows, but it slows interleaved calls alike, so
that table's ratios to SGBM hold.

The first-call cost of each dcstereo method is measured on one scene: the first call in a
child whose ``NUMBA_CACHE_DIR`` is a fresh empty folder (compile), then in a second child
with that folder filled (load from the cache), and the steady-state call.

    python benchmarks/bench_speed.py
    python benchmarks/bench_speed.py --scenes teddy --methods dsi5,opencv-sgbm --threads 1
    python benchmarks/bench_speed.py --skip-large --json speed.json --markdown speed.md
    python benchmarks/bench_speed.py --interleave 21 --json speed.json --markdown SPEED.md
    python benchmarks/bench_speed.py --rounds 3 --interleave 21 --markdown SPEED.md
    python benchmarks/bench_speed.py --same-range --skip-large --threads 1 --interleave 21

With ``--wide``, synthetic pairs of 400 rows and widths up to 16,000 px (``--wide
3000x400x256,16000x400x512`` names others) are measured as the large pair is: the cost of
wide images, whose volumes ``sgm`` splits into tiles. With ``--load N``, ``N`` processes
that each keep a core busy (a Python loop) run while everything is measured, as other work
on a user's machine does; they are stopped at the end.

    python benchmarks/bench_speed.py --scenes none --skip-large --wide --methods sgm,opencv-sgbm
    python benchmarks/bench_speed.py --methods sgm,opencv-sgbm --skip-large --load 1
"""

import argparse
import datetime
import json
import os
import platform
import resource
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

DCSTEREO_METHODS = ("sgm", "block", "dsi3", "dsi5", "dc")
OPENCV_METHODS = ("opencv-bm", "opencv-sgbm", "opencv-hh")
DEFAULT_METHODS = DCSTEREO_METHODS + OPENCV_METHODS
SGBM = "opencv-sgbm"
LARGE_NAME = "synthetic"
RESULT_TAG = "BENCH_SPEED_RESULT "
STRIP_ROWS = 32
WIDE_SIZES = "3000x400x256,6000x400x256,8000x400x256,16000x400x256,16000x400x512"
BUSY_LOOP = "while True: pass"
#: Suffixes of ``sgm``'s name that add one of its stages on request, in any order:
#: ``sgm+photometric+planes`` is ``sgm`` with ``photometric="matched"`` and ``planes=True``,
#: ``+wmedian`` its median weighted by the colours (``median="weighted"``), ``+wplanes`` that
#: median and the local planes (``median="weighted-planes"``), ``+smooth`` its
#: census on intensities smoothed by a Gaussian of 1.2 pixels (``census_smoothing=1.2``),
#: ``+rows`` the right view's rows moved onto the left's (``row_alignment="estimated"``),
#: ``+edges`` its depth edges decided again after the median (``edges="support-weights"``).
STAGE_SUFFIXES = {
    "+photometric": {"photometric": "matched"},
    "+planes": {"planes": True},
    "+wmedian": {"median": "weighted"},
    "+wplanes": {"median": "weighted-planes"},
    "+smooth": {"census_smoothing": 1.2},
    "+rows": {"row_alignment": "estimated"},
    "+edges": {"edges": "support-weights"},
}


# --------------------------------------------------------------------------- inputs


def synthetic_pair(width, height, disparities, seed=0):
    """A textured pair warped by a slanted plane plus a raised rectangle.

    Returns ``(left, right, truth)``: uint8 (H, W) images and the float32 (H, W) disparity
    of the left view, in ``0 .. disparities - 1`` (``x_right = x_left - d``).
    """
    rng = np.random.default_rng(seed)
    top = disparities - 1
    margin = top + 2
    texture = rng.uniform(0.0, 255.0, (height + 2, width + margin + 2)).astype(np.float32)
    # 3x3 binomial smoothing: matchable with sub-pixel warps, still rich in texture.
    texture = 0.25 * texture[:, :-2] + 0.5 * texture[:, 1:-1] + 0.25 * texture[:, 2:]
    texture = 0.25 * texture[:-2] + 0.5 * texture[1:-1] + 0.25 * texture[2:]
    x = np.arange(width, dtype=np.float32)
    y = np.arange(height, dtype=np.float32)[:, None]
    truth = 0.15 * top + 0.45 * top * x / max(width - 1, 1) + 0.1 * top * y / max(height - 1, 1)
    rows = slice(height // 4, height // 2 + height // 8)
    cols = slice(width // 3, width // 3 + width // 4)
    truth[rows, cols] += 0.3 * top
    truth = np.clip(truth, 0.0, top).astype(np.float32)
    right = texture[:, margin:]
    # left(x) = right(x - d): sample the texture at margin + x - d, linearly interpolated.
    position = margin + x - truth
    base = np.floor(position).astype(np.intp)
    fraction = position - base
    left = (1.0 - fraction) * np.take_along_axis(texture, base, axis=1)
    left += fraction * np.take_along_axis(texture, base + 1, axis=1)
    to_uint8 = lambda image: np.clip(np.rint(image), 0, 255).astype(np.uint8)  # noqa: E731
    return to_uint8(left), to_uint8(right), truth


def parse_size(text):
    """``"3000x2000x256"`` -> (width, height, disparities)."""
    try:
        width, height, disparities = (int(part) for part in text.lower().split("x"))
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"expected WIDTHxHEIGHTxDISPARITIES, got {text!r}"
        ) from None
    if min(width, height) < STRIP_ROWS // 2 or disparities < 2:
        raise argparse.ArgumentTypeError(f"too small a pair: {text!r}")
    return width, height, disparities


def load_case(case):
    """``(left, right, min_disparity, max_disparity, truth)`` of a case description.

    With ``case["same_range"]`` the range is widened to OpenCV's
    (``dcstereo.compat.opencv.opencv_num_disparities`` from the same least disparity), so that
    every method searches the same disparities.
    """
    if case["kind"] == "middlebury":
        from dcstereo.evaluation.datasets import load_scene

        scene = load_scene(case["path"])
        left, right, truth = scene.left, scene.right, None
        low, high = scene.min_disparity, scene.max_disparity
    else:
        with np.load(case["path"]) as data:
            left, right, truth = data["left"], data["right"], data["truth"]
        low, high = 0, case["disparities"] - 1
    if case.get("same_range"):
        from dcstereo.compat.opencv import opencv_num_disparities

        high = low + opencv_num_disparities(low, high) - 1
    return left, right, low, high, truth


# --------------------------------------------------------------------------- child side


def memory_status():
    """Current and peak resident set size in bytes from /proc/self/status, or None."""
    try:
        with open("/proc/self/status", encoding="ascii") as stream:
            fields = dict(line.split(":", 1) for line in stream if ":" in line)
        return int(fields["VmRSS"].split()[0]) * 1024, int(fields["VmHWM"].split()[0]) * 1024
    except (OSError, KeyError, ValueError):
        return None


def reset_peak_rss():
    """Reset the kernel's peak-RSS counter (Linux >= 4.0); False when it cannot."""
    try:
        with open("/proc/self/clear_refs", "w", encoding="ascii") as stream:
            stream.write("5")
        return True
    except OSError:
        return False


def max_rss_bytes():
    """``ru_maxrss`` of this process in bytes (Linux reports KiB, macOS bytes)."""
    value = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    return value if sys.platform == "darwin" else value * 1024


def stage_options(method):
    """Split ``method`` into the name ``run_method`` takes and the options of its stages.

    ``"sgm+photometric+planes"`` -> ``("sgm", {"photometric": "matched", "planes": True})``
    (:data:`STAGE_SUFFIXES`); a name without them comes back as it is, with no options.
    """
    options = {}
    while True:
        for suffix, extra in STAGE_SUFFIXES.items():
            if method.endswith(suffix):
                method = method.removesuffix(suffix)
                options.update(extra)
                break
        else:
            return method, options


def make_call(method, left, right, min_disparity, max_disparity):
    """A no-argument matcher call for ``method``; returns (call, disparities searched)."""
    from dcstereo.evaluation.scoring import run_method

    if method in OPENCV_METHODS:
        from dcstereo.compat.opencv import opencv_num_disparities

        # through run_method: SGBM on the colour images when both are (the results' protocol)
        def call():
            return run_method(
                method, left, right, max_disparity=max_disparity, min_disparity=min_disparity
            )

        return call, opencv_num_disparities(min_disparity, max_disparity)

    name, options = stage_options(method)

    def call():  # a name ending in +bt: that method with the Birchfield-Tomasi cost
        return run_method(
            name, left, right, max_disparity=max_disparity, min_disparity=min_disparity,
            **options,
        )  # fmt: skip

    return call, max_disparity - min_disparity + 1


def set_threads(method, threads):
    """Thread count for numba (always) and for OpenCV (for the OpenCV methods)."""
    import numba

    numba.set_num_threads(threads)
    if method in OPENCV_METHODS:
        import cv2

        cv2.setNumThreads(threads)


def timing_row(scene, shape, disparities, method, threads, seconds, repeat):
    """The columns every timing row has: the input, the method, its best call."""
    height, width = shape
    return {
        "scene": scene,
        "height": height,
        "width": width,
        "disparities": int(disparities),
        "method": method,
        "threads": threads,
        "ms": 1e3 * seconds,
        "mde_per_s": height * width * disparities / 1e6 / seconds,
        "repeat": repeat,
    }


def run_interleaved(spec):
    """Time ``spec["methods"]`` at ``spec["threads"]`` in this one process, calls alternating.

    After one warm-up call of each (method, threads) pair, ``spec["repeat"]`` rounds call
    every pair once in turn; the best call of each pair is kept. A shared machine's load
    changes from minute to minute, shifting whole fresh-process rows; calls that alternate
    meet the same load, so their ratios hold. Returns ``{"rows": [...]}``.
    """
    case = spec["case"]
    left, right, min_disparity, max_disparity, _ = load_case(case)
    height, width = left.shape[:2]
    calls = {}
    for method in spec["methods"]:
        calls[method] = make_call(method, left, right, min_disparity, max_disparity)
    pairs = [(method, threads) for threads in spec["threads"] for method in spec["methods"]]
    for method, threads in pairs:
        set_threads(method, threads)
        calls[method][0]()
    best = dict.fromkeys(pairs, float("inf"))
    for _ in range(spec["repeat"]):
        for method, threads in pairs:
            set_threads(method, threads)
            best[method, threads] = min(best[method, threads], timed(calls[method][0]))
    rows = []
    for method, threads in pairs:
        disparities = calls[method][1]
        rows.append(
            timing_row(
                case["name"],
                (height, width),
                disparities,
                method,
                threads,
                best[method, threads],
                spec["repeat"],
            )
        )
    return {"rows": rows}


def run_one(spec):
    """Measure one configuration in this process; returns the result row (a dict)."""
    if spec["mode"] == "interleave":
        return run_interleaved(spec)
    method, threads, case = spec["method"], spec["threads"], spec["case"]
    set_threads(method, threads)
    left, right, min_disparity, max_disparity, truth = load_case(case)
    height, width = left.shape[:2]
    if spec["mode"] == "first":
        call, disparities = make_call(method, left, right, min_disparity, max_disparity)
        start = time.perf_counter()
        call()
        first = time.perf_counter() - start
        best = min(timed(call) for _ in range(spec["repeat"]))
        return {"first_s": first, "steady_ms": 1e3 * best}

    strip = slice(0, min(height, STRIP_ROWS))
    strip_call, _ = make_call(method, left[strip], right[strip], min_disparity, max_disparity)
    strip_call()  # numba compiles or loads its code here, before the memory baseline
    call, disparities = make_call(method, left, right, min_disparity, max_disparity)
    status = memory_status()
    base_maxrss = max_rss_bytes()
    use_proc = status is not None and reset_peak_rss()
    base = status[0] if status is not None else base_maxrss
    setup_peak = status[1] if status is not None else base_maxrss
    if spec["warmup"]:
        call()
    best = float("inf")
    for _ in range(spec["repeat"]):
        start = time.perf_counter()
        result = call()
        best = min(best, time.perf_counter() - start)
    if use_proc:
        calls_peak = memory_status()[1]
        method_bytes = calls_peak - base
        peak = max(setup_peak, calls_peak)
    else:
        method_bytes = max_rss_bytes() - base_maxrss
        peak = max_rss_bytes()
    row = timing_row(
        case["name"], (height, width), disparities, method, threads, best, spec["repeat"]
    )
    row.update(
        {
            "base_mb": base / 2**20,
            "peak_mb": peak / 2**20,
            "method_mb": max(method_bytes, 0) / 2**20,
            "ru_maxrss_mb": max_rss_bytes() / 2**20,
            "memory_source": "VmHWM" if use_proc else "ru_maxrss",
            "warmup": "full" if spec["warmup"] else f"{STRIP_ROWS}-row strip",
        }
    )
    if truth is not None:
        disparity = result.disparity
        known = np.isfinite(disparity)
        row["density"] = float(known.mean())
        row["bad_2"] = float(np.mean(np.abs(disparity[known] - truth[known]) > 2.0))
    return row


def timed(call):
    start = time.perf_counter()
    call()
    return time.perf_counter() - start


# --------------------------------------------------------------------------- parent side


def run_child(spec, env=None, timeout=None):
    """Run ``run_one(spec)`` in a fresh interpreter; returns its row or ``{"error": ...}``."""
    command = [sys.executable, str(Path(__file__).resolve()), "--one", json.dumps(spec)]
    try:
        done = subprocess.run(
            command, capture_output=True, text=True, env=env, timeout=timeout, check=False
        )
    except subprocess.TimeoutExpired:
        return {"error": f"timed out after {timeout} s"}
    for line in done.stdout.splitlines():
        if line.startswith(RESULT_TAG):
            return json.loads(line[len(RESULT_TAG) :])
    lines = (done.stderr or done.stdout).strip().splitlines()
    return {"error": f"exit {done.returncode}: {lines[-1] if lines else 'no output'}"}


def cpu_model():
    """CPU model name from /proc/cpuinfo, else what platform knows."""
    try:
        with open("/proc/cpuinfo", encoding="utf-8") as stream:
            for line in stream:
                if line.startswith("model name"):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine()


def vector_target():
    """What numba compiles for: the CPU name LLVM gives the host and its widest vector unit.

    The band kernels hold ``BAND_ROWS`` = 8 float64 lanes per value: one register with
    AVX-512, two with AVX2, so the same code runs at quite different speeds on the two.
    """
    from dcstereo._vector.simd import compile_target

    name, features = compile_target()
    unit = next(
        (label for flag, label in (("+avx512f", "AVX-512"), ("+avx2", "AVX2"), ("+avx", "AVX"))
         if flag in features),
        "SSE",
    )  # fmt: skip
    return f"{name}, {unit}"


def machine_info(cv2):
    """Where and with what the benchmark ran."""
    import numba

    import dcstereo

    usable = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    return {
        "date": datetime.datetime.now(datetime.UTC).isoformat(timespec="seconds"),
        "platform": platform.platform(),
        "cpu": cpu_model(),
        "vector_target": vector_target(),
        "cpu_count": os.cpu_count(),
        "cpus_usable": usable,
        "python": platform.python_version(),
        "numpy": np.__version__,
        "numba": numba.__version__,
        "numba_threads_max": numba.config.NUMBA_NUM_THREADS,
        "numba_threading_layer": numba.config.THREADING_LAYER,
        "dcstereo": dcstereo.__version__,
        "opencv": cv2.__version__ if cv2 else None,
        "opencv_threads_default": cv2.getNumThreads() if cv2 else None,
    }


def add_ratios(rows):
    """``time_vs_sgbm``: time over SGBM's on the same scene at the same thread count."""
    sgbm = {(r["scene"], r["threads"]): r["ms"] for r in rows if r["method"] == SGBM and "ms" in r}
    for row in rows:
        reference = sgbm.get((row["scene"], row["threads"]))
        row["time_vs_sgbm"] = row["ms"] / reference if reference and "ms" in row else None


def fastest_rows(rounds):
    """Each row of the first round replaced by its fastest repeat over ``rounds``.

    ``rounds`` is a list of row lists, one per sweep, rows keyed by (scene, method,
    threads). A row that failed in every round keeps the first round's error; a row that
    failed in some rounds is taken from those that did not. ``rounds`` on each row: how
    many sweeps timed it.
    """

    def key(row):
        return row["scene"], row["method"], row["threads"]

    timed = {}
    for rows in rounds:
        for row in rows:
            if "ms" in row:
                timed.setdefault(key(row), []).append(row)
    merged = []
    for row in rounds[0]:
        candidates = timed.get(key(row))
        best = dict(min(candidates, key=lambda r: r["ms"]) if candidates else row)
        best["rounds"] = len(candidates or [])
        merged.append(best)
    add_ratios(merged)
    return merged


def speedups(rows, threads):
    """Per (scene, method): time at 1 thread over time at the largest thread count."""
    low, high = min(threads), max(threads)
    times = {(r["scene"], r["method"], r["threads"]): r.get("ms") for r in rows}
    table = []
    for row in rows:
        if row["threads"] != low or high == low:
            continue
        slow = times.get((row["scene"], row["method"], low))
        fast = times.get((row["scene"], row["method"], high))
        table.append(
            {
                "scene": row["scene"],
                "method": row["method"],
                "threads": f"{low}->{high}",
                "ms_low": slow,
                "ms_high": fast,
                "speedup": slow / fast if slow and fast else None,
            }
        )
    return table


def number(value, spec, width):
    return f"{value:{width}{spec}}" if isinstance(value, int | float) else f"{'-':>{width}s}"


COLUMNS = (
    # title, key, format, width
    ("scene", "scene", "s", 9),
    ("size", "size", "s", 9),
    ("D", "disparities", "d", 4),
    ("method", "method", "s", 11),
    ("thr", "threads", "d", 3),
    ("ms", "ms", ".1f", 9),
    ("Mde/s", "mde_per_s", ".1f", 8),
    ("base MB", "base_mb", ".0f", 7),
    ("peak MB", "peak_mb", ".0f", 7),
    ("method MB", "method_mb", ".1f", 9),
    ("x SGBM", "time_vs_sgbm", ".2f", 6),
)


#: The interleaved table: the timing columns of ``COLUMNS`` (no memory: one process runs
#: every method there).
INTERLEAVED_COLUMNS = tuple(
    column for column in COLUMNS if column[1] not in ("size", "base_mb", "peak_mb", "method_mb")
)


def speedup_columns(threads):
    """Columns of the speed-up table, titled with the two thread counts."""
    return (
        ("scene", "scene", "s", 9),
        ("method", "method", "s", 11),
        (f"ms {min(threads)} thr", "ms_low", ".1f", 9),
        (f"ms {max(threads)} thr", "ms_high", ".1f", 9),
        ("speed-up", "speedup", ".2f", 8),
    )


COMPILE_COLUMNS = (
    ("scene", "scene", "s", 9),
    ("method", "method", "s", 11),
    ("compile s", "compile_s", ".2f", 9),
    ("cached s", "cached_s", ".2f", 8),
    ("steady ms", "steady_ms", ".1f", 9),
)


def cells(row, columns):
    out = []
    for _, key, spec, width in columns:
        value = row.get(key)
        if key == "size":
            value = f"{row['width']}x{row['height']}" if "width" in row else "-"
        if spec == "s":
            out.append(f"{str(value):{width}s}" if value is not None else f"{'-':{width}s}")
        else:
            out.append(number(value, spec, width))
    return out


def text_table(rows, columns):
    header = " ".join(
        f"{title:{width}s}" if spec == "s" else f"{title:>{width}s}"
        for title, _, spec, width in columns
    )
    lines = [header, "-" * len(header)]
    for row in rows:
        line = " ".join(cells(row, columns))
        lines.append(line + (f"  error: {row['error']}" if "error" in row else ""))
    return "\n".join(lines)


def markdown_table(rows, columns):
    lines = [
        "| " + " | ".join(title for title, *_ in columns) + " |",
        "|" + "|".join("---" if spec == "s" else "---:" for _, _, spec, _ in columns) + "|",
    ]
    for row in rows:
        values = [cell.strip() for cell in cells(row, columns)]
        if "error" in row:
            values[-1] += f" (error: {row['error']})"
        lines.append("| " + " | ".join(values) + " |")
    return "\n".join(lines)


def machine_line(machine):
    opencv = (
        f"OpenCV {machine['opencv']} (default {machine['opencv_threads_default']} threads)"
        if machine["opencv"]
        else "OpenCV not installed"
    )
    return (
        f"{machine['date']}; {machine['platform']}; CPU: {machine['cpu']} "
        f"({machine.get('vector_target', 'target not recorded')}), "
        f"{machine['cpu_count']} CPUs ({machine['cpus_usable']} usable); Python "
        f"{machine['python']}, numpy {machine['numpy']}, numba {machine['numba']} "
        f"(up to {machine['numba_threads_max']} threads), {opencv}; dcstereo "
        f"{machine['dcstereo']}"
    )


def write_atomic(path, text):
    """Write ``text`` to ``path`` atomically (``dcstereo.io.atomic_write``), making its folder."""
    from dcstereo.io import atomic_write

    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    with atomic_write(path) as tmp:
        tmp.write_text(text, encoding="utf-8")


def output_error(path):
    """Why ``write_atomic`` could not write ``path`` (it makes missing folders), or None.

    Checked before measuring, so that a bad ``--json`` or ``--markdown`` fails at once
    rather than after the whole run.
    """
    from dcstereo.io import check_writable

    if path is None:
        return None
    try:
        check_writable(path, make_folders=True)
    except ValueError as err:
        return str(err)
    return None


def markdown_report(payload):
    settings = payload["settings"]
    parts = [
        "# Speed and memory",
        "",
        "Written by `benchmarks/bench_speed.py` (issue 6); rerun it after changing a kernel:",
        "",
        f"    python benchmarks/bench_speed.py {settings['command']}".rstrip(),
        "",
        f"Machine: {machine_line(payload['machine'])}.",
        "",
        f"Threads: {', '.join(map(str, settings['threads']))} (numba and OpenCV). "
        f"Best of {settings['repeat']} calls after a full-size warm-up on the Middlebury "
        f"scenes; best of {settings['repeat_large']} on the synthetic pair "
        f"({'after a full-size warm-up' if settings['large_warmup'] else 'warmed up on a strip'}"
        "). Each row is a fresh process"
        + (
            f", the fastest of {settings['rounds']} (the whole sweep ran {settings['rounds']} "
            "times, one round after the other; memory columns from that process)."
            if settings.get("rounds", 1) > 1
            else "."
        ),
        "",
        (
            "Disparity ranges: every method searches OpenCV's, each input's range with its "
            "count rounded up to a multiple of 16 (`--same-range`), so every method of a scene "
            "does the same H x W x D evaluations."
            if settings.get("same_range")
            else "Disparity ranges: each input's own; OpenCV rounds the count up to a multiple "
            "of 16, and is credited with what it searched."
        ),
        "",
        "`Mde/s`: million disparity evaluations per second, H x W x D / s, D the disparities "
        "searched (OpenCV: rounded up to a multiple of 16). `base MB`: resident memory "
        "before the measured calls (interpreter, libraries, inputs, compiled code). "
        "`peak MB`: peak resident memory of the process over its life (`VmHWM`; "
        "`ru_maxrss` would include the parent's peak, inherited through fork and exec). "
        "`method MB`: peak resident memory during the calls minus `base`. "
        "`x SGBM`: time over OpenCV StereoSGBM's "
        "(`MODE_SGBM`) at the same thread count.",
        "",
        "## Time and memory",
        "",
        markdown_table(payload["results"], COLUMNS),
    ]
    if payload["speedup"]:
        parts += [
            "",
            "## Speed-up with threads",
            "",
            markdown_table(payload["speedup"], speedup_columns(settings["threads"])),
        ]
    if payload["compile"]:
        parts += [
            "",
            "## First call: compile and cache",
            "",
            "First call (compile plus one run) in a process with an empty `NUMBA_CACHE_DIR`; "
            "first call in a second process with that cache filled; best later call. "
            f"Threads: {payload['compile'][0].get('threads', '-')}.",
            "",
            markdown_table(payload["compile"], COMPILE_COLUMNS),
        ]
    if payload.get("interleaved"):
        parts += [
            "",
            "## Interleaved in one process",
            "",
            f"Each scene's methods in one process per thread count, their calls alternating, "
            f"best of {settings['interleave']} rounds after a warm-up call each: a loaded "
            "period slows them all alike, so these ratios to SGBM hold where a fresh-process "
            "row above may have met other tenants' load.",
            "",
            markdown_table(payload["interleaved"], INTERLEAVED_COLUMNS),
        ]
        if payload.get("interleaved_speedup"):
            parts += [
                "",
                markdown_table(
                    payload["interleaved_speedup"], speedup_columns(settings["threads"])
                ),
            ]
    if payload["notes"]:
        parts += ["", "## Notes", ""] + [f"- {note}" for note in payload["notes"]]
    return "\n".join(parts) + "\n"


#: The line that ends the tables in ``--markdown``'s file: what an existing file has after
#: it is kept when the tables are rewritten (``make bench`` writes docs/speed-tables.md).
NOTES_MARKER = "<!-- bench_speed.py writes the tables above this line and keeps what is below -->"


def kept_notes(path, report):
    """``report`` with the marker, then what the file at ``path`` has after its marker."""
    text = report.rstrip("\n") + "\n\n" + NOTES_MARKER + "\n"
    try:
        old = Path(path).read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError):
        return text
    _, found, notes = old.partition(NOTES_MARKER)
    if not found or not notes.strip():
        return text
    return text + "\n" + notes.lstrip("\n")


def comma_list(text):
    return [part.strip() for part in text.split(",") if part.strip()]


def parse_args(argv):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--one", help=argparse.SUPPRESS)
    parser.add_argument(
        "--scenes",
        help="comma-separated scene folders under the Middlebury folder (any layout) or the "
        "outdoor folder (the KITTI pairs), 'all' (the Middlebury scenes), 'outdoor' (the "
        "KITTI pairs), or 'none' (default: the four v2 scenes)",
    )
    parser.add_argument(
        "--methods",
        default=",".join(DEFAULT_METHODS),
        help="comma-separated methods: dcstereo methods (a name ending in +bt: with the "
        "Birchfield-Tomasi cost; sgm+photometric, sgm+planes, sgm+wmedian, sgm+wplanes, "
        "sgm+smooth, sgm+rows and their combinations: sgm with those stages), opencv-bm, "
        "opencv-sgbm, opencv-hh (default: %(default)s)",
    )
    parser.add_argument(
        "--threads", help="comma-separated thread counts (default: 1 and all cores)"
    )
    parser.add_argument("--repeat", type=int, default=5, help="timed calls per scene (5)")
    parser.add_argument(
        "--repeat-large", type=int, default=1, help="timed calls on the large pair (1)"
    )
    parser.add_argument(
        "--large-warmup",
        action="store_true",
        help="also warm up on the full large pair (default: on a strip only)",
    )
    parser.add_argument("--skip-large", action="store_true", help="leave out the large pair")
    parser.add_argument(
        "--same-range",
        action="store_true",
        help="every method searches OpenCV's disparity range (the input's, its count rounded "
        "up to a multiple of 16); default: each input's own range, which OpenCV rounds up",
    )
    parser.add_argument(
        "--rounds",
        type=int,
        default=1,
        metavar="N",
        help="run the fresh-process sweep N times and keep each row's fastest process (default: 1)",
    )
    parser.add_argument(
        "--interleave",
        type=int,
        default=0,
        metavar="N",
        help="also time the methods of each Middlebury scene in one process per thread count, "
        "their calls alternating, best of N rounds (a table whose ratios hold on a loaded "
        "machine; default: off)",
    )
    parser.add_argument(
        "--large",
        type=parse_size,
        default=(3000, 2000, 256),
        metavar="WxHxD",
        help="size of the synthetic pair (default: 3000x2000x256)",
    )
    parser.add_argument(
        "--compile-scene",
        help="input of the compile-time table (default: tsukuba, else the first input; "
        "'none' skips it)",
    )
    parser.add_argument(
        "--compile-methods",
        help="comma-separated dcstereo methods for the compile-time table "
        "(default: the dcstereo methods benchmarked)",
    )
    parser.add_argument(
        "--timeout", type=float, default=900.0, help="seconds allowed per child process (900)"
    )
    parser.add_argument(
        "--wide",
        nargs="?",
        const=WIDE_SIZES,
        metavar="WxHxD,...",
        help=f"also measure wide synthetic pairs (default sizes: {WIDE_SIZES})",
    )
    parser.add_argument(
        "--load",
        type=int,
        default=0,
        metavar="N",
        help="keep N cores busy with other processes (Python loops) while measuring (0)",
    )
    parser.add_argument("--json", type=Path, help="also write the results to this JSON file")
    parser.add_argument("--markdown", type=Path, help="also write the tables as markdown")
    return parser.parse_args(argv)


def fail(message):
    print(f"error: {message}", file=sys.stderr)
    return 2


def main(argv=None):
    args = parse_args(argv)
    if args.one:
        row = run_one(json.loads(args.one))
        print(RESULT_TAG + json.dumps(row), flush=True)
        return 0

    import numba

    import dcstereo
    from dcstereo.evaluation.datasets import (
        default_data_dir,
        find_scenes,
        list_middlebury,
        middlebury_dir,
    )
    from dcstereo.evaluation.scoring import BT_SUFFIX

    try:
        import cv2
    except ImportError:
        cv2 = None

    for path in (args.json, args.markdown):
        error = output_error(path)
        if error:
            return fail(error)
    methods = comma_list(args.methods)
    bt_methods = [m + BT_SUFFIX for m in dcstereo.METHODS if m != "redert"]
    known = list(dcstereo.METHODS) + bt_methods + list(OPENCV_METHODS)
    staged = [m for m in methods if stage_options(m)[1] and stage_options(m)[0] == "sgm"]
    unknown = [m for m in methods if m not in known and m not in staged]
    if unknown or not methods:
        named = f"unknown method(s) {', '.join(unknown)}" if unknown else "no method given"
        return fail(
            f"--methods: {named}; choose from {', '.join(known)} (sgm may end in "
            f"{' and '.join(STAGE_SUFFIXES)}, its stages on request)"
        )
    if args.compile_methods is not None:
        wrong = [m for m in comma_list(args.compile_methods) if m not in dcstereo.METHODS]
        if wrong:
            return fail(
                f"--compile-methods: not dcstereo method(s) {', '.join(wrong)}; "
                f"choose from {', '.join(dcstereo.METHODS)}"
            )
    notes = []
    if cv2 is None and any(m in OPENCV_METHODS for m in methods):
        methods = [m for m in methods if m not in OPENCV_METHODS]
        notes.append("OpenCV (cv2) is not installed: StereoBM and StereoSGBM are left out.")
        print(notes[-1])
    # SGBM first in each group, so every other row can show its ratio as it is printed.
    methods.sort(key=lambda m: m != SGBM)
    if args.repeat < 1 or args.repeat_large < 1:
        return fail("--repeat and --repeat-large must be at least 1")
    if args.rounds < 1:
        return fail("--rounds must be at least 1")
    if args.interleave < 0:
        return fail("--interleave must be 0 (off) or a number of rounds")
    if not args.timeout > 0:
        return fail(f"--timeout must be a positive number of seconds, got {args.timeout}")
    limit = numba.config.NUMBA_NUM_THREADS
    try:
        threads = [int(t) for t in comma_list(args.threads)] if args.threads else [1, limit]
    except ValueError:
        return fail(f"--threads must be comma-separated integers, got {args.threads!r}")
    threads = sorted(set(threads))
    if not threads or threads[0] < 1 or threads[-1] > limit:
        return fail(f"--threads must lie between 1 and {limit} (numba's limit), got {threads}")

    if args.scenes is None:
        names = list_middlebury()
        folders = {name: middlebury_dir() / name for name in names}
        if not names:
            notes.append(f"No Middlebury scenes at {middlebury_dir()}: set DCSTEREO_DATA.")
            print(notes[-1])
    elif args.scenes.strip().lower() == "none":
        names, folders = [], {}
    else:
        indoor = {folder.name: folder for folder in find_scenes(middlebury_dir())}
        outdoor = {folder.name: folder for folder in find_scenes(default_data_dir() / "outdoor")}
        folders = {**indoor, **outdoor}
        word = args.scenes.strip().lower()
        names = (
            list(indoor) if word == "all" else list(outdoor) if word == "outdoor"
            else comma_list(args.scenes)
        )  # fmt: skip
        missing = [n for n in names if n not in folders]
        if missing:
            return fail(f"unknown scene(s) {', '.join(missing)}; found {list(folders)}")
    cases = [  # "middlebury": a real scene of ground truth (the outdoor pairs as well)
        {"kind": "middlebury", "name": name, "same_range": args.same_range,
         "path": str(folders[name])}
        for name in names
    ]  # fmt: skip

    workdir = Path(tempfile.mkdtemp(prefix="bench_speed_"))
    try:
        if not args.skip_large:
            width, height, disparities = args.large
            left, right, truth = synthetic_pair(width, height, disparities)
            path = workdir / "synthetic.npz"
            np.savez(path, left=left, right=right, truth=truth)
            del left, right, truth
            cases.append(
                {
                    "kind": "synthetic",
                    "name": LARGE_NAME,
                    "path": str(path),
                    "disparities": disparities,
                    "same_range": args.same_range,
                }
            )
        for text in comma_list(args.wide or ""):
            try:
                width, height, disparities = parse_size(text)
            except argparse.ArgumentTypeError as err:
                return fail(f"--wide: {err}")
            left, right, truth = synthetic_pair(width, height, disparities)
            name = f"{width}x{height}x{disparities}"
            path = workdir / f"{name}.npz"
            np.savez(path, left=left, right=right, truth=truth)
            del left, right, truth
            cases.append(
                {
                    "kind": "synthetic",
                    "name": name,
                    "path": str(path),
                    "disparities": disparities,
                    "same_range": args.same_range,
                }
            )
        if not cases:
            return fail("nothing to measure: no scenes and --skip-large")
        if args.load < 0:
            return fail("--load must be 0 or a number of busy processes")
        busy = [subprocess.Popen([sys.executable, "-c", BUSY_LOOP]) for _ in range(args.load)]
        if busy:
            notes.append(f"{len(busy)} busy process(es) (a Python loop each) ran throughout.")
            print(notes[-1])
        try:
            return measure(args, cases, methods, threads, notes, workdir, cv2)
        finally:
            for process in busy:
                process.kill()
                process.wait()
    finally:
        shutil.rmtree(workdir, ignore_errors=True)


def sweep(args, cases, methods, threads):
    """One fresh process per (input, thread count, method), printed as they come; the rows."""
    rows = []
    print(text_table([], COLUMNS), flush=True)
    for case in cases:
        large = case["kind"] == "synthetic"
        for count in threads:
            for method in methods:
                spec = {
                    "case": case,
                    "method": method,
                    "threads": count,
                    "mode": "measure",
                    "repeat": args.repeat_large if large else args.repeat,
                    "warmup": args.large_warmup or not large,
                }
                row = run_child(spec, timeout=args.timeout)
                if "error" in row:
                    row.update(scene=case["name"], method=method, threads=count)
                rows.append(row)
                add_ratios(rows)
                print(text_table([row], COLUMNS).splitlines()[-1], flush=True)
    return rows


def measure(args, cases, methods, threads, notes, workdir, cv2):
    machine = machine_info(cv2)
    print(machine_line(machine))
    print(
        f"threads {threads}; best of {args.repeat} (scenes) / {args.repeat_large} (large) "
        f"calls; one fresh process per row; {args.rounds} round(s)\n",
        flush=True,
    )
    rounds = []
    for number in range(args.rounds):
        if args.rounds > 1:
            print(f"round {number + 1} of {args.rounds}")
        rounds.append(sweep(args, cases, methods, threads))
    rows = fastest_rows(rounds)
    if args.rounds > 1:
        print(f"\nFastest of {args.rounds} rounds\n")
        print(text_table(rows, COLUMNS), flush=True)

    interleaved = []
    if args.interleave > 0:
        print(f"\nInterleaved in one process per scene, best of {args.interleave} rounds\n")
        print(text_table([], INTERLEAVED_COLUMNS), flush=True)
        for case in cases:
            if case["kind"] != "middlebury":
                continue  # the large pair's calls are seconds long: the fresh-process rows
            # one process per thread count: the thread pools of a 2-thread call (numba's
            # OpenMP workers, OpenCV's) still spin after it and would slow 1-thread calls
            for count in threads:
                spec = {
                    "case": case,
                    "mode": "interleave",
                    "methods": methods,
                    "threads": [count],
                    "repeat": args.interleave,
                }
                result = run_child(spec, timeout=args.timeout)
                if "error" in result:
                    notes.append(f"interleaved {case['name']}, {count} thr: {result['error']}")
                    print(notes[-1])
                    continue
                interleaved += result["rows"]
                add_ratios(interleaved)
                for row in result["rows"]:
                    print(text_table([row], INTERLEAVED_COLUMNS).splitlines()[-1], flush=True)

    speedup = speedups(rows, threads)
    if speedup:
        print("\nSpeed-up from", threads[0], "to", threads[-1], "threads\n")
        print(text_table(speedup, speedup_columns(threads)), flush=True)

    compile_rows = first_call_table(args, cases, methods, threads, workdir)
    if compile_rows:
        print(text_table(compile_rows, COMPILE_COLUMNS), flush=True)

    settings = {
        "command": " ".join(sys.argv[1:]) if sys.argv[0].endswith("bench_speed.py") else "",
        "methods": methods,
        "threads": threads,
        "repeat": args.repeat,
        "repeat_large": args.repeat_large,
        "large_warmup": args.large_warmup,
        "large": None if args.skip_large else list(args.large),
        "interleave": args.interleave,
        "rounds": args.rounds,
        "same_range": args.same_range,
        "wide": args.wide,
        "load": args.load,
    }
    payload = {
        "machine": machine,
        "settings": settings,
        "results": rows,
        "speedup": speedup,
        "compile": compile_rows,
        "interleaved": interleaved,
        "interleaved_speedup": speedups(interleaved, threads),
        "notes": notes,
    }
    try:
        if args.json:
            write_atomic(args.json, json.dumps(payload, indent=2) + "\n")
            print(f"\nwrote {args.json}")
        if args.markdown:
            write_atomic(args.markdown, kept_notes(args.markdown, markdown_report(payload)))
            print(f"wrote {args.markdown}")
    except (OSError, ValueError) as err:
        return fail(str(err))
    return 0


def first_call_table(args, cases, methods, threads, workdir):
    """Compile, load-from-cache and steady-state times of the dcstereo methods on one input."""
    if args.compile_methods is not None:
        chosen = comma_list(args.compile_methods)
    else:
        chosen = [m for m in methods if m not in OPENCV_METHODS]
    by_name = {case["name"]: case for case in cases}
    name = args.compile_scene or ("tsukuba" if "tsukuba" in by_name else cases[0]["name"])
    if not chosen or name.lower() == "none":
        return []
    if name not in by_name:
        print(f"\n--compile-scene {name!r} is not among the inputs; compile table left out")
        return []
    count = max(threads)
    print(
        f"\nFirst call on {name} ({count} threads): compile (empty NUMBA_CACHE_DIR), "
        "load from cache (second process), steady state\n",
        flush=True,
    )
    rows = []
    for method in chosen:
        cache = workdir / f"numba_cache_{method}"
        cache.mkdir()
        env = dict(os.environ, NUMBA_CACHE_DIR=str(cache))
        spec = {
            "case": by_name[name],
            "method": method,
            "threads": count,
            "mode": "first",
            "repeat": args.repeat,
        }
        cold = run_child(spec, env=env, timeout=args.timeout)
        warm = run_child(spec, env=env, timeout=args.timeout)
        row = {"scene": name, "method": method, "threads": count}
        row["compile_s"] = cold.get("first_s")
        row["cached_s"] = warm.get("first_s")
        row["steady_ms"] = warm.get("steady_ms", cold.get("steady_ms"))
        errors = [r["error"] for r in (cold, warm) if "error" in r]
        if errors:
            row["error"] = errors[0]
        rows.append(row)
    return rows


if __name__ == "__main__":
    sys.exit(main())
