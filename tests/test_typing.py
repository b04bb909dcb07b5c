"""The public API's type hints: py.typed ships, annotations are complete, mypy is clean."""

import importlib.util
import inspect
import subprocess
import sys
from pathlib import Path

import pytest

import dcstereo

ROOT = Path(__file__).resolve().parents[1]


def test_py_typed_ships():
    assert (Path(dcstereo.__file__).parent / "py.typed").is_file()
    assert 'dcstereo = ["py.typed"]' in (ROOT / "pyproject.toml").read_text()


@pytest.mark.parametrize(
    "name", [n for n in dcstereo.__all__ if inspect.isfunction(getattr(dcstereo, n))]
)
def test_exported_functions_are_annotated(name):
    signature = inspect.signature(getattr(dcstereo, name))
    missing = [
        p
        for p, v in signature.parameters.items()
        if v.annotation is inspect.Parameter.empty and v.kind not in (v.VAR_KEYWORD,)
    ]
    assert not missing, f"{name}: parameters without a type hint: {missing}"
    assert signature.return_annotation is not inspect.Signature.empty, f"{name}: no return type"


@pytest.mark.slow
def test_mypy_clean_on_public_modules():
    """mypy with pyproject.toml's [tool.mypy] (the public modules; about 20 s)."""
    if importlib.util.find_spec("mypy") is None:
        pytest.skip("mypy is not installed (the test extra brings it)")
    done = subprocess.run(
        [sys.executable, "-m", "mypy", "--no-incremental"],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert done.returncode == 0, done.stdout + done.stderr
