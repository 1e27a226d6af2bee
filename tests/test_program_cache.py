"""The persistent program cache (engine/gpu/program_binaries.py): a second process loads
the programs the first compiled, and a damaged entry or a cache that cannot be written
costs only the speed-up, never the image. Each render runs in its own process, with
its own cache folder."""
import json
import os
import subprocess
import sys

import numpy as np
import pytest

SCENE = "usdskel/usd/usdSkel/doxygen/skinnedArm.usda"   # skinned: transform feedback too

RENDER = """
import json, sys
import numpy as np
from lantern.engine import RenderSettings, Session
from lantern.engine.gpu.context import run_gl
from lantern.engine.usd.opening import open_stage
with Session(open_stage(sys.argv[1]), RenderSettings(width=64, height=36, preset="low")) as s:
    result = s.render()
np.save(sys.argv[2], result.rgba)
print(json.dumps({"compiled": result.stats["programs_compiled"],
                  "loaded": result.stats["programs_loaded"],
                  "binaries": run_gl(lambda gl: gl.loader.active)}))
"""


def _render(corpus, tmp_path, cache, name, **env):
    out = tmp_path / f"{name}.npy"
    environ = dict(os.environ, LANTERN_PROGRAM_CACHE_DIR=str(cache))
    environ.pop("LANTERN_NO_PROGRAM_CACHE", None)
    environ.update(env)
    proc = subprocess.run([sys.executable, "-c", RENDER, str(corpus / SCENE), str(out)],
                          capture_output=True, text=True, env=environ)
    assert proc.returncode == 0, proc.stderr
    assert proc.stderr == "", f"the cache must stay silent without --debug:\n{proc.stderr}"
    return json.loads(proc.stdout.splitlines()[-1]), np.load(out)


@pytest.fixture
def reference(corpus, tmp_path):
    """The image with the cache off, and the number of programs it takes."""
    stats, image = _render(corpus, tmp_path, tmp_path / "unused", "reference",
                           LANTERN_NO_PROGRAM_CACHE="1")
    assert stats["loaded"] == 0 and stats["compiled"] > 0
    assert not (tmp_path / "unused").exists(), "LANTERN_NO_PROGRAM_CACHE=1 wrote a cache"
    return stats["compiled"], image


def _filled_cache(corpus, tmp_path, reference):
    cache = tmp_path / "cache"
    stats, image = _render(corpus, tmp_path, cache, "first")
    if not stats["binaries"]:
        pytest.skip("this GL driver offers no program binary format")
    assert stats == {"compiled": reference[0], "loaded": 0, "binaries": True}
    assert np.array_equal(image, reference[1])
    entries = sorted(cache.iterdir())
    assert len(entries) == reference[0]
    return cache, entries


def test_a_second_process_loads_the_first_ones_programs(corpus, tmp_path, reference):
    cache, _ = _filled_cache(corpus, tmp_path, reference)
    stats, image = _render(corpus, tmp_path, cache, "second")
    assert stats["compiled"] == 0
    assert stats["loaded"] == reference[0]
    assert np.array_equal(image, reference[1])


def test_damaged_entries_are_rebuilt_and_render_the_same(corpus, tmp_path, reference):
    cache, entries = _filled_cache(corpus, tmp_path, reference)
    truncated, flipped, foreign, empty, rejected = entries[:5]
    truncated.write_bytes(truncated.read_bytes()[:-100])
    data = bytearray(flipped.read_bytes())
    data[-10] ^= 0xFF
    flipped.write_bytes(bytes(data))
    foreign.write_bytes(entries[5].read_bytes())        # another program's entry
    empty.write_bytes(b"")
    # Well-formed, but not a binary the driver takes: glProgramBinary fails, and the
    # program is compiled after all.
    from lantern.engine.gpu import program_binaries as pb
    fmt, _ = pb.decode_entry(bytes.fromhex(rejected.stem), rejected.read_bytes())
    rejected.write_bytes(pb.encode_entry(bytes.fromhex(rejected.stem), fmt, b"not a program" * 50))
    stats, image = _render(corpus, tmp_path, cache, "damaged")
    assert stats == {"compiled": 5, "loaded": reference[0] - 5, "binaries": True}
    assert np.array_equal(image, reference[1])
    # Rebuilt in place: the next process compiles nothing.
    stats, image = _render(corpus, tmp_path, cache, "repaired")
    assert stats["compiled"] == 0
    assert np.array_equal(image, reference[1])


@pytest.mark.parametrize("kind", ["read-only folder", "folder under a file"])
def test_a_cache_that_cannot_be_written_renders_the_same(corpus, tmp_path, reference, kind):
    if kind == "read-only folder":
        cache = tmp_path / "readonly"
        cache.mkdir()
        cache.chmod(0o555)
        if os.access(cache, os.W_OK):       # root writes there anyway: take a folder
            cache.chmod(0o755)              # of a file system nobody writes files in
            if not sys.platform.startswith("linux"):
                pytest.skip("this user writes into read-only folders")
            cache = "/proc/self"
    else:
        (tmp_path / "file").write_text("not a folder")
        cache = tmp_path / "file" / "programs"
    try:
        for name in ("first", "second"):
            stats, image = _render(corpus, tmp_path, cache, name)
            assert stats["compiled"] == reference[0] and stats["loaded"] == 0
            assert np.array_equal(image, reference[1])
    finally:
        if kind == "read-only folder" and cache != "/proc/self":
            cache.chmod(0o755)


def test_only_debug_says_an_entry_was_rebuilt(corpus, tmp_path):
    cache = tmp_path / "cache"
    environ = dict(os.environ, LANTERN_PROGRAM_CACHE_DIR=str(cache))
    environ.pop("LANTERN_NO_PROGRAM_CACHE", None)

    def render(*extra):
        proc = subprocess.run([sys.executable, "-m", "lantern", "render", str(corpus / SCENE),
                               "-o", str(tmp_path / "arm.exr"), "--size", "32x18", *extra],
                              capture_output=True, text=True, env=environ)
        assert proc.returncode == 0, proc.stderr
        return proc.stderr

    render()
    entries = sorted(cache.iterdir())
    if not entries:
        pytest.skip("this GL driver offers no program binary format")
    for entry in entries:
        entry.write_bytes(entry.read_bytes()[:-1])
    assert render() == ""
    for entry in entries:
        entry.write_bytes(entry.read_bytes()[:-1])
    said = render("--debug")
    assert said.count("program cache:") == len(entries), said
    assert "truncated" in said


def test_the_compilers_helper_stores_a_binary_or_says_why_it_cannot(tmp_path, monkeypatch):
    """engine/gpu/compiler.py's helper makes a program into the cache folder, where the
    render process finds it; a helper whose GL differs from the render context's is
    not used (what was handed over is then compiled in place)."""
    from lantern.core import cache_folder
    from lantern.engine.gpu.compiler import BackgroundCompiler
    from lantern.engine.gpu.context import run_gl
    monkeypatch.setenv("LANTERN_PROGRAM_CACHE_DIR", str(tmp_path))
    key = ("fullscreen.vert", "depth_copy.frag", ("HELPER_TEST",), (), False, (), ())

    def driver(gl):
        info = gl.ctx.info
        return info["GL_VENDOR"], info["GL_RENDERER"], info["GL_VERSION"], gl.loader.active
    *same, active = run_gl(driver)
    if not active or cache_folder.disabled():
        pytest.skip("this driver stores no program binaries")
    helper = BackgroundCompiler(tuple(same))
    try:
        assert helper.submit(key, key) and helper.wait(timeout=120)
        assert helper.broken is None and helper.failure(key) is None
        assert run_gl(lambda gl: gl.programs.ready(*key))       # stored: a load away
        assert len(os.listdir(tmp_path)) == 1
    finally:
        helper.close()
    other = BackgroundCompiler(("another vendor", "another GPU", "9.9"))
    try:
        other.submit(key, key)
        assert other.wait(timeout=120)
        assert "not the render context's" in other.broken
    finally:
        other.close()


def test_a_program_the_helper_keeps_too_long_is_made_in_place():
    """A helper that never answers does not hold a viewport on the old variant: after
    compiler.PATIENCE the program counts as failed there, so the render process makes
    it itself (ProgramCache.ready)."""
    import time
    from lantern.engine.gpu import compiler
    helper = compiler.BackgroundCompiler(("v", "r", "1"))
    helper._pending["late"] = time.monotonic() - compiler.PATIENCE - 1.0
    helper._pending["recent"] = time.monotonic()
    assert helper.pending() == 1
    assert "not made within" in helper.failure("late") and helper.failure("recent") is None


def test_shader_sources_follow_their_files(tmp_path, monkeypatch):
    """A program's sources are assembled from files read once per version: an edited
    include is read again (a long-lived engine host picks up a shader being worked
    on), each include appears once, and defines follow #version."""
    from lantern.engine.gpu import programs
    monkeypatch.setattr(programs, "SHADER_DIR", str(tmp_path))
    (tmp_path / "main.frag").write_text('#version 330 core\n#include "lib.glsl"\n'
                                        '#include "lib.glsl"\nvoid main() {}\n')
    lib = tmp_path / "lib.glsl"
    lib.write_text("float one() { return 1.0; }\n")
    first = programs.load_source("main.frag", ("RED",))
    assert first == ("#version 330 core\n#define RED\nfloat one() { return 1.0; }\n"
                     "\n\nvoid main() {}\n")      # an include line's own newline stays
    lib.write_text("float two() { return 2.0; }\n")
    stat = lib.stat()
    os.utime(lib, ns=(stat.st_atime_ns, stat.st_mtime_ns + 1_000_000))
    assert "two()" in programs.load_source("main.frag") and "one()" not in \
        programs.load_source("main.frag")
