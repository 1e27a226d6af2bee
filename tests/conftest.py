"""Test set-up shared by every test.

The suite runs in one process that imports bpy, so pxr there must be Blender's own
USD (a bpy process may never load a second one). `lantern.exporters` arranges that
on import, so it goes first, before any test module imports pxr. The CLI tests run
`lantern render file.usd` in subprocesses without bpy, which use usd-core.
"""
import atexit
import os
import pathlib
import shutil
import sys
import tempfile

import pytest

import lantern.exporters  # noqa: F401  (must precede any pxr import)

REPO = pathlib.Path(__file__).resolve().parent.parent
CORPUS = REPO.parent / "shared" / "corpus"

# The persistent program cache (engine/gpu/program_binaries.py) of this test run: a
# temporary folder, never the user's, set before any test module copies os.environ for
# the subprocesses it starts.
PROGRAM_CACHE = tempfile.mkdtemp(prefix="lantern-test-programs-")
os.environ["LANTERN_PROGRAM_CACHE_DIR"] = PROGRAM_CACHE
atexit.register(shutil.rmtree, PROGRAM_CACHE, True)

# This suite runs on machines without a GPU (Mesa's llvmpipe): it expects the CPU, so no
# render here, in this process or in any it starts (the CLI, farm workers, the engine
# host in Blender), warns about rendering on it (engine/gpu/devices.py). A run that
# must use a GPU sets LANTERN_REQUIRE_GPU=1 itself.
os.environ.setdefault("LANTERN_REQUIRE_GPU", "0")

# Shared test modules (calibration scenes and closed forms) live beside the tests.
sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent))


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
