"""Test set-up shared by every test.

The suite runs in one process that imports bpy, so pxr there must be Blender's own
USD (a bpy process may never load a second one). `lantern.exporters` arranges that
on import, so it goes first, before any test module imports pxr. The CLI tests run
`lantern render file.usd` in subprocesses without bpy, which use usd-core.
"""
import os
import pathlib
import sys

import pytest

import lantern.exporters  # noqa: F401  (must precede any pxr import)

REPO = pathlib.Path(__file__).resolve().parent.parent
CORPUS = REPO.parent / "shared" / "corpus"

# Shared test modules (calibration scenes and closed forms) live beside the tests.
sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent))


@pytest.fixture(scope="session", autouse=True)
def program_cache(tmp_path_factory):
    """The persistent program cache (engine/gpu/program_binaries.py) of this test run:
    a temporary folder, never the user's, shared by the subprocesses tests start."""
    folder = tmp_path_factory.mktemp("program-cache")
    before = os.environ.get("LANTERN_PROGRAM_CACHE_DIR")
    os.environ["LANTERN_PROGRAM_CACHE_DIR"] = str(folder)
    yield folder
    if before is None:
        os.environ.pop("LANTERN_PROGRAM_CACHE_DIR", None)
    else:
        os.environ["LANTERN_PROGRAM_CACHE_DIR"] = before


@pytest.fixture(scope="session")
def corpus():
    """../shared/corpus, read in place (never copied)."""
    if not CORPUS.is_dir():
        pytest.fail(f"the shared corpus is missing: {CORPUS}")
    return CORPUS


@pytest.fixture
def empty_scene():
    """A factory-empty Blender scene."""
    import bpy
    bpy.ops.wm.read_factory_settings(use_empty=True)
    return bpy.context.scene
