"""The kernels' on-disk cache is keyed by all their sources (dcstereo._vector._cache)."""

import importlib
import pkgutil
import shutil
import subprocess
import sys
import textwrap

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


@pytest.mark.parametrize("install", [True, False])
def test_an_edit_of_a_callee_reaches_its_cached_caller(tmp_path, install):
    """Two processes, the callee's file edited between them; numba's cache folder kept.

    With the locator, the second process runs the new callee. Without it (numba's own
    per-file stamp), it loads the caller compiled against the old one: the reason the
    locator exists.
    """
    package = tmp_path / "pkg" / "kernels"
    package.mkdir(parents=True)
    (tmp_path / "pkg" / "__init__.py").write_text("")
    shutil.copy(_cache.__file__, package / "_cache.py")
    init = "from ._cache import install_locator\ninstall_locator()\n" if install else ""
    (package / "__init__.py").write_text(init)
    (package / "caller.py").write_text(textwrap.dedent(_CALLER))
    (package / "callee.py").write_text(textwrap.dedent(_CALLEE).format(1))
    env = {"NUMBA_CACHE_DIR": str(tmp_path / "cache"), "PYTHONPATH": str(tmp_path)}
    run = [sys.executable, "-c", "from pkg.kernels.caller import caller; print(caller())"]

    def result():
        done = subprocess.run(run, env=env, capture_output=True, text=True, check=True)
        return int(done.stdout)

    assert result() == 2
    (package / "callee.py").write_text(textwrap.dedent(_CALLEE).format(10))
    assert result() == (11 if install else 2)
