"""numba's on-disk cache, made safe across the kernel modules.

numba keys each cached kernel on the hash of the source file that defines it (its
"source stamp"). A kernel that calls a function of another file keeps its cached machine
code when only that other file changes, and runs the old callee: the reason the kernels
used to live in two files of 1,700 and 3,600 lines. :class:`KernelCacheLocator` stamps
every kernel of this package with the hash of all the package's sources instead
(:func:`sources_digest`), so an edit anywhere in it recompiles every kernel on the next
run, and nothing stale is ever loaded. Where the cache lives is unchanged: the locator
numba would have chosen (``NUMBA_CACHE_DIR``, else ``__pycache__`` beside the sources,
else the user's cache folder) gives the folder. The plain forms of the vector operations
(``DCSTEREO_VECTOR=0``) compile to other code under the same names, so they are kept in a
folder ``plain`` inside it: a stamp of their own in the same index files would make each
kind of run throw the other's kernels away.

The locator is put first in numba's list of locators (``CacheImpl._locator_classes``) and
answers only for the files of this package. ``tests/test_kernel_cache.py`` checks that it
is in place for every kernel, and that an edit of a callee's file reaches its caller
through the cache.
"""

import functools
import hashlib
import os
from pathlib import Path

from numba.core import caching

from . import VECTOR

#: The folder whose ``*.py`` files (at any depth) make the stamp.
PACKAGE_DIR = Path(__file__).resolve().parent.parent


def sources_digest(root: Path = PACKAGE_DIR) -> str:
    """Return the SHA-256 of every ``*.py`` file under ``root`` but the command line's, sorted.

    Names and contents. The kernels live by stage all over the package and read constants
    of other modules (the flags of ``result.py``), so every module counts, but for
    ``cli/``: the command line calls the library and no kernel reads it.
    """
    digest = hashlib.sha256()
    for path in sorted(root.rglob("*.py")):
        if path.relative_to(root).parts[0] == "cli":
            continue
        source = path.read_bytes()
        digest.update(path.relative_to(root).as_posix().encode())
        digest.update(b"\0")
        digest.update(source)
        digest.update(b"\0")
    return digest.hexdigest()


@functools.lru_cache(maxsize=1)
def _package_digest() -> str:
    # once per process: the sources do not change under a running program
    return sources_digest(PACKAGE_DIR)


#: The folder, inside numba's, of the kernels compiled with ``DCSTEREO_VECTOR=0``.
PLAIN_FOLDER = "plain"


def _inside(py_file: str) -> bool:
    try:
        return Path(py_file).resolve().is_relative_to(PACKAGE_DIR)
    except (OSError, ValueError):
        return False


class KernelCacheLocator(caching._CacheLocator):
    """Cache locator of the kernels of this package: numba's folder, the package's stamp."""

    def __init__(self, inner):
        self._inner = inner

    def get_cache_path(self):  # noqa: D102 (numba's interface)
        # the plain forms compile to other code than the vector forms (dcstereo._vector's
        # VECTOR, the flag the kernels were compiled with)
        path = self._inner.get_cache_path()
        return path if VECTOR else os.path.join(path, PLAIN_FOLDER)

    def get_source_stamp(self):  # noqa: D102
        return _package_digest()

    def get_disambiguator(self):  # noqa: D102
        return self._inner.get_disambiguator()

    @classmethod
    def from_function(cls, py_func, py_file):
        """Wrap the locator numba would use, for a function defined in this package only."""
        if not _inside(py_file):
            return None
        for other in caching.CacheImpl._locator_classes:
            if other is cls:
                continue
            inner = other.from_function(py_func, py_file)
            if inner is not None:
                return cls(inner)
        return None


def install_locator() -> None:
    """Put :class:`KernelCacheLocator` first in numba's locators (once)."""
    classes = caching.CacheImpl._locator_classes
    if KernelCacheLocator not in classes:
        classes.insert(0, KernelCacheLocator)
