"""``sgm`` on images larger than its volume bound, many callers at once, and a busy machine.

Tiles (``sgm.tiles``): the kept parts cover the image once, each tile's volumes within the
bound; where every tile's context reaches the image's edges the result is the whole-image
one bit for bit, elsewhere it differs only near the cuts. The volume pool: four threads at
once give the serial results within ``WORKSPACE_BYTES``. A busy machine (processes started
here) changes nothing in the results. Speed is measured in ``benchmarks/bench_speed.py``
(``--wide``, ``--load``), never here.
"""

import os
import subprocess
import sys
import threading
import time

import numba
import numpy as np
import pytest

from dcstereo import _threads
from dcstereo._vector import sgm as sgm_simd
from dcstereo.costs import census as census_kernels
from dcstereo.methods import sgm
from dcstereo.params import MatchParams
from dcstereo.signal import padded_signal


def _pair(height, width, shift, seed):
    """A textured pair whose left view is the right one moved ``shift`` pixels right."""
    rng = np.random.default_rng(seed)
    texture = rng.integers(0, 256, (height, width + shift + 1), dtype=np.uint8)
    texture = ((texture[:, :-1].astype(np.int32) + texture[:, 1:]) // 2).astype(np.uint8)
    left = texture[:, :width]
    right = texture[:, shift : shift + width]
    return np.ascontiguousarray(left), np.ascontiguousarray(right)


def _bound_pixels(monkeypatch, pixels, lanes=16):
    """Make the volume bound ``pixels`` pixels of ``lanes`` lanes."""
    monkeypatch.setattr(sgm, "VOLUME_BYTES", pixels * 6 * lanes)


def _covered(plan, height, width):
    kept = np.zeros((height, width), dtype=np.int64)
    for (_, s0, s1, _), (_, k0, k1, _) in plan:
        kept[s0:s1, k0:k1] += 1
    return kept


@pytest.mark.parametrize(
    ("height", "width", "pixels"),
    [
        (40, 50, 40 * 50),  # fits: one tile
        (20, 3000, 20 * 300),  # wide: columns
        (3000, 20, 20 * 300),  # tall: rows
        (400, 700, 150 * 150),  # both
        (97, 1013, 65 * 65 + 7),  # odd sizes, the smallest tiles
        (5, 9000, 70 * 70),
    ],
)
def test_tiles_cover_the_image_once_within_the_bound(monkeypatch, height, width, pixels):
    _bound_pixels(monkeypatch, pixels)
    margin = sgm.STRIP_MARGIN
    plan = sgm.tiles(height, width, 16)
    assert np.all(_covered(plan, height, width) == 1)
    for (m0, s0, s1, m1), (c0, k0, k1, c1) in plan:
        assert (m0, c0) == (max(0, s0 - margin), max(0, k0 - margin))
        assert (m1, c1) == (min(height, s1 + margin), min(width, k1 + margin))
        assert s1 > s0 and k1 > k0
        assert (m1 - m0) * (c1 - c0) <= max(pixels, (2 * margin + 1) ** 2)
    if height * width <= pixels:
        assert plan == [((0, 0, height, height), (0, 0, width, width))]


def test_wide_images_cost_what_their_pixels_cost(monkeypatch):
    # the old strips computed 64 rows of context for 1 kept at this bound; tiles of columns
    # compute a few per cent more than the image
    height, width = 40, 4000
    _bound_pixels(monkeypatch, 40 * 700)
    plan = sgm.tiles(height, width, 16)
    work = sum((r[3] - r[0]) * (c[3] - c[0]) for r, c in plan)
    assert work <= 1.15 * height * width


@pytest.mark.parametrize("colour", [False, True])
def test_tile_costs_equal_the_image_costs_away_from_the_cuts(colour):
    rng = np.random.default_rng(8)
    shape = (9, 70, 3) if colour else (9, 70)
    left = rng.integers(0, 256, shape, dtype=np.uint8)
    right = rng.integers(0, 256, shape, dtype=np.uint8)
    dmin, dmax, box = -2, 9, 3
    params = MatchParams(method="sgm", min_disparity=dmin, max_disparity=dmax, window=box)
    ndisp, lanes = params.num_disparities, 16
    codes = []
    for image in (left, right):
        out = np.empty(image.shape[:2], dtype=np.uint32)
        sgm._census(padded_signal(image, 0), 5, 5, out)
        codes.append(out)
    colour_l, colour_r = sgm.colour_channels(left, right)
    codes = [census_kernels.code_planes(c) for c in codes]
    codes_r = sgm._reversed_right(codes[1], dmax, -dmin)
    colour_r = sgm._reversed_right(colour_r, dmax, -dmin)

    def volume(c0, c1):
        inputs = sgm.tile_columns(codes[0], codes_r, colour_l, colour_r, c0, c1, True)
        out = np.empty((9, c1 - c0, lanes), dtype=np.int16)
        reciprocal = sgm.check_sgm_bounds(params)
        census_kernels.cost_volume(*inputs, dmin, ndisp, 4, 20, box, reciprocal, 999, 0, out)
        return out

    whole = volume(0, 70)
    for c0, c1 in [(0, 30), (17, 52), (40, 70), (33, 34 + box)]:
        tile = volume(c0, c1)
        inner = slice(1 if c0 else 0, (c1 - c0) - (1 if c1 < 70 else 0))
        np.testing.assert_array_equal(tile[:, inner], whole[:, c0:c1][:, inner])


def test_tiles_whose_context_reaches_the_edges_give_the_whole_image_result(monkeypatch):
    # every tile computes the whole image, keeps a part: the stitching and the left-right
    # check on whole rows are exact
    left, right = _pair(30, 60, 5, seed=3)
    params = MatchParams(method="sgm", max_disparity=12, fill=False, median=0)
    whole = sgm.match_sgm(left, right, params)
    confidence = sgm.sgm_confidence(left, right, params)
    grid = [((0, 0, 11, 30), (0, 0, 17, 60)), ((0, 0, 11, 30), (0, 17, 60, 60))]
    grid += [((0, 11, 30, 30), (0, k0, k1, 60)) for k0, k1 in [(0, 5), (5, 41), (41, 60)]]
    monkeypatch.setattr(sgm, "tiles", lambda height, width, lanes: grid)
    tiled = sgm.match_sgm(left, right, params)
    np.testing.assert_array_equal(tiled.disparity, whole.disparity)
    np.testing.assert_array_equal(tiled.flags, whole.flags)
    np.testing.assert_array_equal(sgm.sgm_confidence(left, right, params), confidence)


@pytest.mark.parametrize(
    ("height", "width", "pixels"),
    [(24, 1200, 24 * 150), (600, 40, 40 * 150), (180, 260, 110 * 110)],
)
def test_tiled_results_differ_from_the_whole_only_near_the_cuts(monkeypatch, height, width, pixels):
    left, right = _pair(height, width, 6, seed=height)
    params = MatchParams(method="sgm", max_disparity=15, fill=False, median=0)
    whole = sgm.match_sgm(left, right, params)
    _bound_pixels(monkeypatch, pixels)
    assert len(sgm.tiles(height, width, 16)) > 2
    tiled = sgm.match_sgm(left, right, params)
    same = (tiled.flags == whole.flags) & (
        (tiled.disparity == whole.disparity)
        | (np.isnan(tiled.disparity) & np.isnan(whole.disparity))
    )
    assert same.mean() > 0.99
    both = np.isfinite(tiled.disparity) & np.isfinite(whole.disparity)
    assert np.abs(tiled.disparity[both] - whole.disparity[both]).max() <= 1.0
    truth = np.isfinite(tiled.disparity)
    assert np.mean(np.abs(tiled.disparity[truth] - 6) <= 1) > 0.98


@numba.njit(parallel=True)
def _count_tasks(tasks, threads):
    done = np.zeros(tasks, dtype=np.int64)
    counter = np.zeros(1, dtype=np.int64)
    for _ in numba.prange(threads):
        task = sgm_simd.next_task(counter)
        while task < tasks:
            done[task] += 1
            task = sgm_simd.next_task(counter)
    return done


def test_task_counter_hands_out_each_task_once():
    counter = np.zeros(1, dtype=np.int64)
    assert [sgm_simd.next_task(counter) for _ in range(3)] == [0, 1, 2]
    for tasks in (1, 7, 5000):
        assert np.all(_count_tasks(tasks, max(2, numba.get_num_threads())) == 1)


# --------------------------------------------------------------------------- many callers


def _pairs():
    return [_pair(40 + 7 * i, 90 + 13 * i, 3 + i, seed=i) for i in range(4)]


def _same(a, b):
    np.testing.assert_array_equal(a.disparity, b.disparity)
    np.testing.assert_array_equal(a.flags, b.flags)


def _at_once(pairs, params):
    results = [None] * len(pairs)
    start = threading.Barrier(len(pairs))

    def call(i):
        start.wait()
        results[i] = sgm.match_sgm(*pairs[i], params)

    workers = [threading.Thread(target=call, args=(i,)) for i in range(len(pairs))]
    for worker in workers:
        worker.start()
    for worker in workers:
        worker.join()
    return results


@pytest.mark.parametrize("tight", [False, True])
def test_four_callers_at_once_match_serial_within_the_bound(monkeypatch, tight):
    pairs = _pairs()
    params = MatchParams(method="sgm", max_disparity=10, fill=False, median=0)
    serial = [sgm.match_sgm(left, right, params) for left, right in pairs]
    largest = max(3 * 2 * 16 * left.size for left, _ in pairs)
    if tight:  # room for one call and a half: the others wait for the volumes to come back
        monkeypatch.setattr(sgm, "WORKSPACE_BYTES", largest * 3 // 2)
        monkeypatch.setattr(sgm, "KEPT_BYTES", largest)
    sgm.release_workspace()
    for results in (_at_once(pairs, params), _at_once(pairs[::-1], params)[::-1]):
        for got, expected in zip(results, serial, strict=True):
            _same(got, expected)
    held = sgm.workspace_bytes()
    assert held["in_use"] == 0
    assert held["kept"] <= sgm.KEPT_BYTES
    assert held["peak"] <= sgm.WORKSPACE_BYTES
    sgm.release_workspace()
    assert sgm.workspace_bytes()["kept"] == 0


def test_kept_volumes_are_freed_when_idle(monkeypatch):
    monkeypatch.setattr(sgm, "IDLE_SECONDS", 0.05)
    left, right = _pair(30, 50, 2, seed=1)
    sgm.match_sgm(left, right, MatchParams(method="sgm", max_disparity=6))
    deadline = time.monotonic() + 10.0
    while sgm.workspace_bytes()["kept"] and time.monotonic() < deadline:
        time.sleep(0.02)
    assert sgm.workspace_bytes()["kept"] == 0


def test_calls_reuse_the_kept_volumes():
    sgm.release_workspace()
    left, right = _pair(30, 50, 2, seed=1)
    params = MatchParams(method="sgm", max_disparity=6)
    sgm.match_sgm(left, right, params)
    kept = sgm.workspace_bytes()["kept"]
    assert kept > 0
    sgm.match_sgm(left[:20], right[:20], params)  # a smaller call takes the same set
    assert sgm.workspace_bytes() == {"in_use": 0, "kept": kept, "peak": kept}
    sgm.release_workspace()


# --------------------------------------------------------------------------- busy machine


@pytest.mark.parametrize("busy", [1, 2])
def test_busy_machine_changes_no_result(busy):
    left, right = _pair(120, 200, 7, seed=5)
    params = MatchParams(method="sgm", max_disparity=20)
    quiet = sgm.match_sgm(left, right, params)
    loops = [subprocess.Popen([sys.executable, "-c", "while True: pass"]) for _ in range(busy)]
    threads = numba.get_num_threads()
    try:
        time.sleep(0.2)
        loaded = sgm.match_sgm(left, right, params)
        numba.set_num_threads(1)
        alone = sgm.match_sgm(left, right, params)
    finally:
        numba.set_num_threads(threads)
        for loop in loops:
            loop.kill()
            loop.wait()
    _same(loaded, quiet)
    _same(alone, quiet)


def test_free_threads_leaves_the_cores_other_work_takes():
    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    assert sgm.free_threads(1, "0.0 0.0 0.0 1/90 7") == 1
    assert sgm.free_threads(4, "0.0 0.0 0.0 1/90 7") == min(4, cores)  # the caller alone
    assert sgm.free_threads(4, f"5.0 5.0 5.0 {cores + 3}/90 7") == 1  # every core taken
    assert sgm.free_threads(4, "garbled", "max 100000") == 4  # unknown: numba's count
    # a container's CPU quota (cgroup v2 cpu.max; v1's quota and period read the same way)
    idle = "0.0 0.0 0.0 1/90 7"
    assert sgm.free_threads(4, idle, "100000 100000") == 1
    assert sgm.free_threads(4, idle, "150000 100000") == min(2, cores)  # 1.5 cores: 2
    assert sgm.free_threads(4, "garbled", "200000 100000") == 2
    assert sgm.free_threads(4, idle, "max 100000") == min(4, cores)  # no quota
    assert sgm.free_threads(4, idle, "-1 100000") == min(4, cores)  # v1: no quota
    # the process's own running threads are not other work: after a parallel loop numba's
    # workers still spin for a moment (before: 2 running, the caller and a spinning worker,
    # left one thread of two on an idle 2-core machine)
    two = "0.0 0.0 0.0 2/90 7"
    assert sgm.free_threads(4, two, "max 1", own=2) == min(4, cores)
    assert sgm.free_threads(4, two, "max 1", own=1) == max(1, min(4, cores - 1))
    assert sgm.free_threads(4, f"5.0 5.0 5.0 {cores + 2}/90 7", "max 1", own=2) == 1


def test_own_running_counts_the_caller_and_numbas_workers_not_other_callers():
    # tasks: the caller (10), a numba worker still spinning (11), a sleeping one (12) and
    # another Python thread, another caller's, running (13): that one is other work
    states = {10: "R", 11: "R", 12: "S", 13: "R"}
    assert _threads.own_running(states, callers={13}) == 2
    assert _threads.own_running(states, callers=set()) == 3
    assert _threads.own_running({}, callers=set()) == 1  # unreadable: the caller alone
    # this process: the caller reads its own state while it runs, and is no other caller
    assert _threads._task_states()[threading.get_native_id()] == "R"


def test_quota_cores_reads_the_cgroup_text():
    assert _threads.quota_cores("max 100000\n") is None
    assert _threads.quota_cores("-1 100000") is None
    assert _threads.quota_cores("50000 100000") == 1  # half a core: one thread
    assert _threads.quota_cores("200000 100000") == 2
    assert _threads.quota_cores("250000 100000") == 3
    assert _threads.quota_cores("garbled") is None
    assert _threads.quota_cores("100 0") is None
    # this machine's own files: a whole number of cores, or no quota
    own = _threads.quota_cores()
    assert own is None or own >= 1
    threads = numba.get_num_threads()
    with sgm.threads_with_cores():
        assert 1 <= numba.get_num_threads() <= threads
    assert numba.get_num_threads() == threads
