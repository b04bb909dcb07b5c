"""The wheel and the sdist: built, checked, and the wheel installed into a clean venv.

The install test is slow (5.7 minutes on a 2-core VM shared with other jobs, load 8 to
11: the build, a virtual environment, numba, scikit-image and the rest installed from the
package index, and the kernels' first compile for `dcstereo demo`).
"""

import os
import subprocess
import sys
import tarfile
import zipfile
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGE = ROOT / "src" / "dcstereo"


def run(command, *, timeout, **kwargs):
    """Run a command; fail with the tail of its output when it fails."""
    done = subprocess.run(
        [str(part) for part in command],
        capture_output=True,
        text=True,
        timeout=timeout,
        check=False,
        **kwargs,
    )
    if done.returncode != 0:
        tail = (done.stdout + done.stderr).strip().splitlines()[-30:]
        pytest.fail(f"{command[0]} {command[1:3]} failed ({done.returncode}):\n" + "\n".join(tail))
    return done


@pytest.fixture(scope="module")
def dist(tmp_path_factory):
    pytest.importorskip("build")
    out = tmp_path_factory.mktemp("dist")
    run([sys.executable, "-m", "build", "--outdir", out, ROOT], timeout=900)
    return out


def only(paths):
    paths = list(paths)
    assert len(paths) == 1, paths
    return paths[0]


def test_the_wheel_carries_the_package_and_nothing_else(dist):
    wheel = only(dist.glob("dcstereo-*.whl"))
    names = set(zipfile.ZipFile(wheel).namelist())
    sources = {
        f"dcstereo/{path.relative_to(PACKAGE).as_posix()}"
        for path in PACKAGE.rglob("*")
        if path.is_file() and "__pycache__" not in path.parts
    }
    assert sources <= names
    ours = {name for name in names if not name.startswith("dcstereo-")}
    assert ours == sources  # no tests, scripts, benchmarks, docs or data
    metadata = zipfile.ZipFile(wheel).read(
        only(n for n in names if n.endswith(".dist-info/METADATA"))
    )
    text = metadata.decode()
    for extra in ("demo", "opencv", "rerun", "test"):
        assert f"Provides-Extra: {extra}" in text
    assert "Requires-Dist: rerun-sdk" in text and 'extra == "rerun"' in text
    entry_points = zipfile.ZipFile(wheel).read(
        only(n for n in names if n.endswith(".dist-info/entry_points.txt"))
    )
    assert "dcstereo = dcstereo.cli:main" in entry_points.decode()


def test_the_sdist_builds_the_wheel_without_the_test_suite(dist):
    sdist = only(dist.glob("dcstereo-*.tar.gz"))
    with tarfile.open(sdist) as archive:
        names = {name.split("/", 1)[1] for name in archive.getnames() if "/" in name}
    assert {
        "pyproject.toml",
        "README.md",
        "src/dcstereo/__init__.py",
        "src/dcstereo/cli/run.py",
    } <= names
    assert not [name for name in names if name.startswith(("tests/", "scripts/", "docs/"))]


@pytest.mark.slow
def test_the_wheel_installs_and_runs_in_a_clean_environment(dist, tmp_path):
    wheel = only(dist.glob("dcstereo-*.whl"))
    venv = tmp_path / "venv"
    run([sys.executable, "-m", "venv", venv], timeout=300)
    python = venv / "bin" / "python"
    # the environment of a user's shell: nothing of this checkout on the path, numba's cache
    # of its own (the installed package compiles its kernels afresh)
    env = {k: v for k, v in os.environ.items() if not k.startswith(("PYTHON", "NUMBA_"))}
    env["NUMBA_CACHE_DIR"] = str(tmp_path / "numba-cache")
    env["PATH"] = f"{venv / 'bin'}{os.pathsep}{env.get('PATH', '')}"
    env.pop("VIRTUAL_ENV", None)
    run([python, "-m", "pip", "install", "--quiet", f"{wheel}[demo]"], timeout=1200, env=env)
    where = run(
        [python, "-I", "-c", "import dcstereo; print(dcstereo.__file__, dcstereo.__version__)"],
        timeout=300,
        cwd=tmp_path,
        env=env,
    ).stdout
    path, version = where.split()
    assert Path(path).is_relative_to(venv) and "site-packages" in path
    assert not Path(path).is_relative_to(ROOT)
    assert version == "0.1.0"
    demo = run([venv / "bin" / "dcstereo", "demo", "--output", tmp_path / "demo"], timeout=1200,
               cwd=tmp_path, env=env)  # fmt: skip
    assert "Middlebury 2014 Motorcycle" in demo.stdout and "bad-1.0" in demo.stdout
    assert (tmp_path / "demo" / "disparity.pfm").is_file()
    assert (tmp_path / "demo" / "cloud.ply").is_file()
    # the extras it was not given: the library still imports, a feature says which to add
    extras = run(
        [python, "-I", "-c", "import dcstereo.viz as v\ntry:\n    v._import_rerun()\n"
         "except ImportError as e:\n    print(e)"],
        timeout=300, cwd=tmp_path, env=env,
    ).stdout  # fmt: skip
    assert 'pip install "dcstereo[rerun]"' in extras
