"""Smoke test of benchmarks/bench_speed.py on a tiny synthetic pair (no timing assertions)."""

import importlib.util
import json
import math
from pathlib import Path

import numpy as np
import pytest

SCRIPT = Path(__file__).resolve().parents[1] / "benchmarks" / "bench_speed.py"


@pytest.fixture(scope="module")
def bench():
    spec = importlib.util.spec_from_file_location("bench_speed", SCRIPT)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_synthetic_pair_follows_its_disparity(bench):
    left, right, truth = bench.synthetic_pair(60, 40, 8, seed=1)
    assert left.shape == right.shape == truth.shape == (40, 60)
    assert left.dtype == right.dtype == np.uint8
    assert 0.0 <= truth.min() and truth.max() <= 7.0
    # left(x) = right(x - d), linearly interpolated and rounded to uint8.
    columns = np.arange(60, dtype=np.float64)
    for row in range(40):
        inside = columns - truth[row] >= 0
        expected = np.interp(columns - truth[row], columns, right[row].astype(np.float64))
        assert np.abs(left[row, inside] - expected[inside]).max() <= 1.0


def run_tiny(bench, tmp_path, methods, compile_methods=None):
    """Run the script on a tiny synthetic pair.

    ``compile_methods``: the methods of its compile-time table (each compiled from nothing
    in a child, a minute a method on a slow host); none by default.
    """
    out_json = tmp_path / "speed.json"
    out_md = tmp_path / "speed.md"
    code = bench.main(
        [
            "--scenes",
            "none",
            "--large",
            "60x40x8",
            "--methods",
            ",".join(methods),
            "--threads",
            "1",
            "--repeat",
            "1",
            *(
                ["--compile-methods", compile_methods]
                if compile_methods
                else ["--compile-scene", "none"]
            ),
            "--json",
            str(out_json),
            "--markdown",
            str(out_md),
        ]
    )
    assert code == 0
    return json.loads(out_json.read_text()), out_md.read_text()


def is_number(value):
    return isinstance(value, int | float) and math.isfinite(value)


def test_dcstereo_methods_table(bench, tmp_path):
    payload, markdown = run_tiny(bench, tmp_path, ["block", "dsi5"], compile_methods="block")
    rows = payload["results"]
    assert [(r["scene"], r["method"], r["threads"]) for r in rows] == [
        ("synthetic", "block", 1),
        ("synthetic", "dsi5", 1),
    ]
    for row in rows:
        assert "error" not in row
        assert (row["height"], row["width"], row["disparities"]) == (40, 60, 8)
        for key in ("ms", "mde_per_s", "base_mb", "peak_mb", "method_mb"):
            assert is_number(row[key]), key
        assert row["peak_mb"] >= row["base_mb"] > 0
        assert row["time_vs_sgbm"] is None  # no SGBM row to compare with
    (compiled,) = payload["compile"]
    assert compiled["method"] == "block"
    assert all(is_number(compiled[k]) for k in ("compile_s", "cached_s", "steady_ms"))
    assert payload["speedup"] == []  # one thread count only
    assert "| synthetic | 60x40 | 8 | block | 1 |" in markdown
    assert "## First call: compile and cache" in markdown
    # the machine line says what numba compiled for (CPU name, widest vector unit)
    name, unit = payload["machine"]["vector_target"].split(", ")
    assert name and unit in ("AVX-512", "AVX2", "AVX", "SSE")
    assert f"({name}, {unit})" in markdown


def test_opencv_rows_and_ratios(bench, tmp_path):
    pytest.importorskip("cv2")
    payload, _ = run_tiny(bench, tmp_path, ["block", "opencv-bm", "opencv-sgbm"])
    rows = payload["results"]
    # SGBM runs first in its group so the others can be compared with it as they print.
    assert [r["method"] for r in rows] == ["opencv-sgbm", "block", "opencv-bm"]
    by_method = {r["method"]: r for r in rows}
    assert by_method["opencv-sgbm"]["disparities"] == 16  # 8 rounded up to 16
    assert by_method["opencv-sgbm"]["time_vs_sgbm"] == pytest.approx(1.0)
    for row in rows:
        assert "error" not in row
        for key in ("ms", "mde_per_s", "base_mb", "peak_mb", "method_mb", "time_vs_sgbm"):
            assert is_number(row[key]), key


def test_speedups_and_ratios_from_rows(bench):
    rows = [
        {"scene": "s", "method": "opencv-sgbm", "threads": 1, "ms": 10.0},
        {"scene": "s", "method": "dsi5", "threads": 1, "ms": 20.0},
        {"scene": "s", "method": "opencv-sgbm", "threads": 2, "ms": 8.0},
        {"scene": "s", "method": "dsi5", "threads": 2, "ms": 10.0},
    ]
    bench.add_ratios(rows)
    assert [r["time_vs_sgbm"] for r in rows] == [1.0, 2.0, 1.0, 1.25]
    table = bench.speedups(rows, [1, 2])
    assert [(r["method"], r["speedup"]) for r in table] == [("opencv-sgbm", 1.25), ("dsi5", 2.0)]


def test_bad_arguments_fail_cleanly(bench, capsys):
    assert bench.main(["--scenes", "none", "--skip-large"]) == 2
    assert bench.main(["--methods", "nosuch", "--skip-large"]) == 2
    assert bench.main(["--threads", "0", "--skip-large"]) == 2
    assert "error:" in capsys.readouterr().err


def test_interleaved_child_times_every_pair(bench, tmp_path):
    left, right, truth = bench.synthetic_pair(60, 40, 8, seed=2)
    path = tmp_path / "pair.npz"
    np.savez(path, left=left, right=right, truth=truth)
    case = {"kind": "synthetic", "name": "tiny", "path": str(path), "disparities": 8}
    spec = {
        "case": case,
        "mode": "interleave",
        "methods": ["block", "dsi5"],
        "threads": [1],
        "repeat": 2,
    }
    rows = bench.run_one(spec)["rows"]
    assert [(r["method"], r["threads"]) for r in rows] == [("block", 1), ("dsi5", 1)]
    for row in rows:
        assert (row["scene"], row["height"], row["width"], row["disparities"]) == (
            "tiny",
            40,
            60,
            8,
        )
        assert is_number(row["ms"]) and row["ms"] > 0
        assert row["mde_per_s"] == pytest.approx(40 * 60 * 8 / 1e3 / row["ms"])


def test_interleaved_table_in_the_markdown(bench):
    rows = [
        {"scene": "s", "disparities": 16, "method": "opencv-sgbm", "threads": 1, "ms": 10.0},
        {"scene": "s", "disparities": 16, "method": "dc", "threads": 1, "ms": 9.0},
    ]
    bench.add_ratios(rows)
    payload = {
        "machine": bench.machine_info(None),
        "settings": {
            "command": "",
            "threads": [1],
            "repeat": 1,
            "repeat_large": 1,
            "large_warmup": False,
            "interleave": 5,
        },
        "results": [],
        "speedup": [],
        "compile": [],
        "interleaved": rows,
        "interleaved_speedup": [],
        "notes": [],
    }
    markdown = bench.markdown_report(payload)
    assert "## Interleaved in one process" in markdown
    assert "best of 5 rounds" in markdown
    assert "| s | 16 | dc | 1 | 9.0 |" in markdown
    assert "0.90" in markdown  # dc over SGBM


def test_bad_interleave_fails_cleanly(bench, capsys):
    assert bench.main(["--interleave", "-1", "--scenes", "none"]) == 2
    assert "--interleave" in capsys.readouterr().err


def test_fastest_rows_takes_each_rows_quickest_round(bench):
    def row(method, threads, ms, **extra):
        return {"scene": "s", "method": method, "threads": threads, "ms": ms, **extra}

    first = [
        row("opencv-sgbm", 1, 10.0, peak_mb=5.0),
        row("dsi5", 1, 9.0, peak_mb=1.0),
        row("dsi5", 2, 7.0),  # a loaded 2-thread row
        {"scene": "s", "method": "dc", "threads": 1, "error": "boom"},
        {"scene": "s", "method": "block", "threads": 1, "error": "first"},
    ]
    second = [
        row("opencv-sgbm", 1, 12.0, peak_mb=6.0),
        row("dsi5", 1, 5.0, peak_mb=2.0),
        row("dsi5", 2, 3.0),
        row("dc", 1, 15.0),
        {"scene": "s", "method": "block", "threads": 1, "error": "second"},
    ]
    merged = bench.fastest_rows([first, second])
    # the first round's order; each row its fastest round, memory from that process
    assert [(r["method"], r["threads"], r.get("ms")) for r in merged] == [
        ("opencv-sgbm", 1, 10.0),
        ("dsi5", 1, 5.0),
        ("dsi5", 2, 3.0),
        ("dc", 1, 15.0),
        ("block", 1, None),
    ]
    assert merged[0]["peak_mb"] == 5.0 and merged[1]["peak_mb"] == 2.0
    assert [r["rounds"] for r in merged] == [2, 2, 2, 1, 0]
    assert merged[4]["error"] == "first"  # failed in every round: the first error
    assert "error" not in merged[3]  # failed once, timed once
    # ratios from the merged rows, not from either round
    assert merged[1]["time_vs_sgbm"] == pytest.approx(0.5)
    assert merged[3]["time_vs_sgbm"] == pytest.approx(1.5)
    assert first[1]["ms"] == 9.0  # the inputs are left alone
    assert bench.speedups(merged, [1, 2])[1]["speedup"] == pytest.approx(5.0 / 3.0)


def test_rounds_in_the_run_and_the_markdown(bench, tmp_path):
    out_json = tmp_path / "speed.json"
    code = bench.main(
        [
            "--scenes", "none", "--large", "40x24x8", "--methods", "block",
            "--threads", "1", "--repeat", "1", "--compile-scene", "none",
            "--rounds", "2", "--json", str(out_json),
        ]
    )  # fmt: skip
    assert code == 0
    payload = json.loads(out_json.read_text())
    (only,) = payload["results"]
    assert only["rounds"] == 2 and is_number(only["ms"])
    assert payload["settings"]["rounds"] == 2
    markdown = bench.markdown_report(payload)
    assert "the fastest of 2 (the whole sweep ran 2 times" in markdown


def test_markdown_keeps_the_notes_below_the_marker(bench, tmp_path):
    # the tables are rewritten, the hand-written notes after the marker kept (docs/SPEED.md)
    path = tmp_path / "SPEED.md"
    assert bench.kept_notes(path, "# tables\n") == f"# tables\n\n{bench.NOTES_MARKER}\n"
    path.write_text(f"# old tables\n\n{bench.NOTES_MARKER}\n\n## A change\n\nmeasured\n")
    written = bench.kept_notes(path, "# new tables\n")
    assert written == f"# new tables\n\n{bench.NOTES_MARKER}\n\n## A change\n\nmeasured\n"
    assert "old tables" not in written
    path.write_text("# a file without the marker\n")
    assert "without" not in bench.kept_notes(path, "# tables\n")
    # through main: a second run keeps the notes a person added below the first run's tables
    _, first = run_tiny(bench, tmp_path, ["block"])
    assert first.endswith(bench.NOTES_MARKER + "\n")
    (tmp_path / "speed.md").write_text(first + "\n## Notes on a change\n")
    _, second = run_tiny(bench, tmp_path, ["block"])
    assert second.count(bench.NOTES_MARKER) == 1 and second.endswith("\n## Notes on a change\n")


def test_bad_rounds_fail_cleanly(bench, capsys):
    assert bench.main(["--rounds", "0", "--scenes", "none"]) == 2
    assert "--rounds" in capsys.readouterr().err


def test_same_range_gives_every_method_opencvs_disparities(bench, tmp_path):
    left, right, truth = bench.synthetic_pair(60, 40, 8, seed=3)
    path = tmp_path / "pair.npz"
    np.savez(path, left=left, right=right, truth=truth)
    case = {"kind": "synthetic", "name": "tiny", "path": str(path), "disparities": 20}
    assert bench.load_case(case)[2:4] == (0, 19)
    assert bench.load_case({**case, "same_range": True})[2:4] == (0, 31)
    assert bench.load_case({**case, "disparities": 32, "same_range": True})[2:4] == (0, 31)
    from dcstereo.compat.opencv import opencv_num_disparities

    assert opencv_num_disparities(-3, 12) == 16
    assert opencv_num_disparities(-3, 13) == 32
    out_json = tmp_path / "speed.json"
    out_md = tmp_path / "speed.md"
    args = ["--scenes", "none", "--large", "60x40x8", "--methods", "dsi5", "--threads", "1"]
    args += ["--repeat", "1", "--compile-scene", "none", "--same-range"]
    assert bench.main(args + ["--json", str(out_json), "--markdown", str(out_md)]) == 0
    payload = json.loads(out_json.read_text())
    assert payload["settings"]["same_range"] is True
    (row,) = payload["results"]
    assert row["disparities"] == 16
    assert "every method searches OpenCV's" in out_md.read_text()


def test_bad_outputs_and_options_fail_before_measuring(bench, tmp_path, capsys):
    plain = tmp_path / "file"
    plain.write_text("x")
    base = ["--scenes", "none", "--large", "60x40x8", "--methods", "block", "--threads", "1"]
    assert bench.main(base + ["--json", str(tmp_path)]) == 2
    assert "is a directory" in capsys.readouterr().err
    assert bench.main(base + ["--markdown", str(plain / "speed.md")]) == 2
    assert "not a directory" in capsys.readouterr().err
    assert bench.main(base + ["--timeout", "0"]) == 2
    assert "--timeout" in capsys.readouterr().err
    assert bench.main(["--methods", ",", "--skip-large"]) == 2
    assert bench.main(base + ["--compile-methods", "nosuch"]) == 2
    assert "--compile-methods" in capsys.readouterr().err
    assert plain.read_text() == "x" and sorted(tmp_path.iterdir()) == [plain]


def test_bt_methods_run_with_the_birchfield_tomasi_cost(bench, tmp_path):
    # "dsi5+bt" times dsi5 with cost="bt": its call gives that result, not the SAD one
    import dcstereo

    left, right, _ = bench.synthetic_pair(60, 40, 8, seed=3)
    call, disparities = bench.make_call("dsi5+bt", left, right, 0, 7)
    assert disparities == 8
    got = call()
    assert got.params.cost == "bt"
    expected = dcstereo.match(left, right, max_disparity=7, method="dsi5", cost="bt")
    assert got.disparity.tobytes() == expected.disparity.tobytes()
    assert bench.main(["--methods", "redert+bt", "--skip-large"]) == 2


def test_stage_suffixes_run_sgm_with_its_stages(bench, tmp_path, capsys):
    # "sgm+photometric+planes" times sgm with both stages on request, in either order
    import dcstereo

    assert bench.stage_options("sgm") == ("sgm", {})
    assert bench.stage_options("sgm+wmedian") == ("sgm", {"median": "weighted"})
    assert bench.stage_options("sgm+smooth") == ("sgm", {"census_smoothing": 1.2})
    assert bench.stage_options("sgm+rows") == ("sgm", {"row_alignment": "estimated"})
    assert bench.stage_options("sgm+edges") == ("sgm", {"edges": "support-weights"})
    assert bench.stage_options("sgm+wplanes") == ("sgm", {"median": "weighted-planes"})
    assert bench.stage_options("sgm+planes+photometric") == (
        "sgm",
        {"planes": True, "photometric": "matched"},
    )
    left, right, _ = bench.synthetic_pair(120, 80, 8, seed=4)
    call, disparities = bench.make_call("sgm+photometric+planes", left, right, 0, 7)
    assert disparities == 8
    got = call()
    assert got.params.planes is True and got.params.photometric == "matched"
    expected = dcstereo.match(left, right, max_disparity=7, photometric="matched", planes=True)
    assert got.disparity.tobytes() == expected.disparity.tobytes()
    # a stage suffix on another method is refused by name
    assert bench.main(["--methods", "dsi5+planes", "--skip-large"]) == 2
    assert "dsi5+planes" in capsys.readouterr().err


def test_outdoor_pairs_are_scenes_by_name(bench, tmp_path, monkeypatch):
    # a one-pair KITTI folder under <data>/outdoor: named alone, or all of them by 'outdoor'
    from test_kitti import write_pair_folder

    write_pair_folder(tmp_path / "data" / "outdoor" / "kitti_toy")
    monkeypatch.setenv("DCSTEREO_DATA", str(tmp_path / "data"))
    for scenes in ("kitti_toy", "outdoor"):
        out = tmp_path / f"{scenes}.json"
        args = ["--scenes", scenes, "--skip-large", "--methods", "block", "--threads", "1",
                "--repeat", "1", "--compile-scene", "none", "--json", str(out)]  # fmt: skip
        assert bench.main(args) == 0
        rows = json.loads(out.read_text())["results"]
        assert [(r["scene"], r["method"], r["disparities"]) for r in rows] == [
            ("kitti_toy", "block", 12)  # meta.json's ndisp
        ]
    assert bench.main(["--scenes", "kitti_nowhere", "--skip-large"]) == 2
