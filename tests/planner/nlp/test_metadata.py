"""Gait-file metadata helpers (`planner.nlp.metadata`)."""

from __future__ import annotations

from importlib import metadata as importlib_metadata

import pytest

from planner.nlp.metadata import distribution_version, package_versions


@pytest.mark.parametrize("name", ["gaitsmith", "casadi", "mujoco", "numpy", "typer"])
def test_distribution_version_is_importlib_metadatas(name: str) -> None:
    assert distribution_version(name) == importlib_metadata.version(name)


def test_an_unknown_distribution_raises_as_importlib_metadata_does() -> None:
    with pytest.raises(importlib_metadata.PackageNotFoundError):
        distribution_version("no-such-distribution-gaitsmith")


def test_package_versions_names_every_package() -> None:
    versions = package_versions()
    assert set(versions) == {"python", "gaitsmith", "casadi", "mujoco", "numpy", "scipy"}
    assert versions["casadi"] == importlib_metadata.version("casadi")
