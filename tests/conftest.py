"""Shared fixtures: where the Middlebury development data lives."""

import pytest

from dcstereo.datasets import list_middlebury, middlebury_dir


@pytest.fixture(scope="session")
def middlebury_root():
    """The Middlebury scene folder, or skip the test when the data is absent."""
    folder = middlebury_dir()
    if not list_middlebury():
        pytest.skip(f"Middlebury dev data not found at {folder}; set DCSTEREO_DATA")
    return folder
