"""Run at the start of every Python process a test starts (the conftest puts this folder
on ``PYTHONPATH``): where the run asks for it (``DCSTEREO_TEST_CACHE_LOCK=1``), the shared
numba cache's lock is installed when numba's dispatcher module is first imported, so that
a process imports numba when it would have, after setting what it sets."""

import importlib.abc
import importlib.util
import os
import sys


class _InstallAfterImport(importlib.abc.MetaPathFinder):
    name = "numba.core.dispatcher"

    def find_spec(self, fullname, path, target=None):
        if fullname != self.name:
            return None
        sys.meta_path.remove(self)
        spec = importlib.util.find_spec(fullname)
        if spec is None or spec.loader is None:
            return spec
        exec_module = spec.loader.exec_module

        def exec_and_install(module):
            exec_module(module)
            import kernel_cache_lock

            kernel_cache_lock.install()

        spec.loader.exec_module = exec_and_install
        return spec


if os.environ.get("DCSTEREO_TEST_CACHE_LOCK") == "1":
    sys.meta_path.insert(0, _InstallAfterImport())
