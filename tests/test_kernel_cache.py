"""The kernels' on-disk cache is keyed by all their sources (dcstereo._vector._cache)."""

import importlib
import os
import pkgutil
import shutil
import subprocess
import sys
import textwrap
from pathlib import Path

import numba
import pytest

import dcstereo
from dcstereo._vector import _cache


def _kernel_modules():
    """Every module of the package but the command line's (the kernels live by stage)."""
    for info in pkgutil.walk_packages(dcstereo.__path__, "dcstereo."):
        if not info.name.startswith("dcstereo.cli"):
            yield importlib.import_module(info.name)


def test_every_cached_kernel_uses_the_package_locator():
    seen = 0
    for module in _kernel_modules():
        for value in vars(module).values():
            if isinstance(value, numba.core.dispatcher.Dispatcher) and value._cache is not None:
                locator = getattr(value._cache, "_impl", None)
                if locator is None:  # a NullCache: cache=False
                    continue
                assert isinstance(locator._locator, _cache.KernelCacheLocator), value
                assert locator._locator.get_source_stamp() == _cache.sources_digest()
                seen += 1
    assert seen > 0


def test_digest_follows_every_file(tmp_path):
    (tmp_path / "a.py").write_text("x = 1\n")
    (tmp_path / "sub").mkdir()
    (tmp_path / "sub" / "b.py").write_text("y = 2\n")
    first = _cache.sources_digest(tmp_path)
    assert _cache.sources_digest(tmp_path) == first
    (tmp_path / "sub" / "b.py").write_text("y = 3\n")
    assert _cache.sources_digest(tmp_path) != first
    (tmp_path / "sub" / "b.py").write_text("y = 2\n")
    assert _cache.sources_digest(tmp_path) == first
    (tmp_path / "c.py").write_text("")
    assert _cache.sources_digest(tmp_path) != first
    second = _cache.sources_digest(tmp_path)
    (tmp_path / "cli").mkdir()
    (tmp_path / "cli" / "run.py").write_text("z = 1\n")  # the command line: no kernel reads it
    assert _cache.sources_digest(tmp_path) == second


_CALLER = """
import numba
from .callee import value

@numba.njit(cache=True)
def caller():
    return value() + 1
"""

_CALLEE = """
import numba

@numba.njit(cache=True)
def value():
    return {}
"""


def _kernel_package(tmp_path, install):
    """``pkg.kernels`` under ``tmp_path``: a copy of the cache module, its package's flag
    ``VECTOR`` read as ``dcstereo._vector`` reads it, the locator installed or not, a
    caller and its callee (returning 1); return the package's folder."""
    package = tmp_path / "pkg" / "kernels"
    package.mkdir(parents=True)
    (tmp_path / "pkg" / "__init__.py").write_text("")
    shutil.copy(_cache.__file__, package / "_cache.py")
    init = 'import os\nVECTOR = os.environ.get("DCSTEREO_VECTOR", "1").strip() != "0"\n'
    if install:
        init += "from ._cache import install_locator\ninstall_locator()\n"
    (package / "__init__.py").write_text(init)
    (package / "caller.py").write_text(textwrap.dedent(_CALLER))
    (package / "callee.py").write_text(textwrap.dedent(_CALLEE).format(1))
    return package


@pytest.mark.parametrize("install", [True, False])
def test_an_edit_of_a_callee_reaches_its_cached_caller(tmp_path, install):
    """Two processes, the callee's file edited between them; numba's cache folder kept.

    With the locator, the second process runs the new callee. Without it (numba's own
    per-file stamp), it loads the caller compiled against the old one: the reason the
    locator exists.
    """
    package = _kernel_package(tmp_path, install)
    env = {"NUMBA_CACHE_DIR": str(tmp_path / "cache"), "PYTHONPATH": str(tmp_path)}
    run = [sys.executable, "-c", "from pkg.kernels.caller import caller; print(caller())"]

    def result():
        done = subprocess.run(run, env=env, capture_output=True, text=True, check=True)
        return int(done.stdout)

    assert result() == 2
    (package / "callee.py").write_text(textwrap.dedent(_CALLEE).format(10))
    assert result() == (11 if install else 2)


def test_the_plain_forms_keep_a_folder_of_their_own(tmp_path):
    """Runs with ``DCSTEREO_VECTOR=0`` and without take turns on one cache folder.

    Each finds its kernels where it left them (a cache hit from the second run of each
    kind on); with one folder and a stamp of its own, each run threw the other's away.
    """
    _kernel_package(tmp_path, install=True)
    cache = tmp_path / "cache"
    code = (
        "from pkg.kernels.caller import caller; caller(); "
        "print(sum(caller.stats.cache_hits.values()))"
    )

    def hits(plain):
        env = {"NUMBA_CACHE_DIR": str(cache), "PYTHONPATH": str(tmp_path)}
        if plain:
            env["DCSTEREO_VECTOR"] = "0"
        run = [sys.executable, "-c", code]
        return int(subprocess.run(run, env=env, capture_output=True, text=True, check=True).stdout)

    assert [hits(plain) for plain in (False, True, False, True)] == [0, 0, 1, 1]
    plain_folders = [path for path in cache.rglob(_cache.PLAIN_FOLDER) if path.is_dir()]
    assert len(plain_folders) == 1 and any(plain_folders[0].glob("caller.*.nbi"))


def test_processes_of_the_test_run_compile_a_kernel_once(tmp_path):
    """The test run's shared cache (tests/_site/kernel_cache_lock.py): processes started at
    once on an empty folder compile a function once; the others wait and load it."""
    body = "\n".join(f"    x = x * 0.5 + {i}.0" for i in range(400))
    (tmp_path / "slow_kernel.py").write_text(
        f"import numba\n\n@numba.njit(cache=True)\ndef kernel(x):\n{body}\n    return x\n"
    )
    code = (
        "import slow_kernel as m; m.kernel(1.0); "
        "print(sum(m.kernel.stats.cache_misses.values()), m.kernel(1.0))"
    )
    site = str(Path(__file__).resolve().parent / "_site")
    env = {
        **os.environ,
        "NUMBA_CACHE_DIR": str(tmp_path / "cache"),
        "DCSTEREO_TEST_CACHE_LOCK": "1",
        "PYTHONPATH": os.pathsep.join([site, str(tmp_path)]),
    }
    runs = [
        subprocess.Popen([sys.executable, "-c", code], env=env, stdout=subprocess.PIPE, text=True)
        for _ in range(3)
    ]
    outs = [run.communicate(timeout=600)[0].split() for run in runs]
    assert all(run.returncode == 0 for run in runs)
    assert sorted(int(misses) for misses, _ in outs) == [0, 0, 1]
    assert len({value for _, value in outs}) == 1
