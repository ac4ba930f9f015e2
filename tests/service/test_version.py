"""The version is written once (pyproject.toml) and read from the installed package's metadata."""

import tomllib
from importlib.metadata import version
from pathlib import Path

import pytest

from service.app import VERSION

ROOT = Path(__file__).resolve().parents[2]


@pytest.mark.slow
def test_version_comes_from_the_package_metadata(client):
    declared = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["version"]
    assert VERSION == version("zwidth") == declared
    assert client.get("/healthz").json()["version"] == VERSION
    assert client.get("/openapi.json").json()["info"]["version"] == VERSION
