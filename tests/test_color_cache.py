"""Display transforms kept in the cache folder (engine/color_cache.py): a new process
builds the same processor from the stored ops, and only what maps colours exactly as
the config does is stored."""
import os
import shutil

import numpy as np
import pytest

pytest.importorskip("PyOpenColorIO")


@pytest.fixture
def cache(tmp_path, monkeypatch):
    monkeypatch.setenv("LANTERN_PROGRAM_CACHE_DIR", str(tmp_path))
    monkeypatch.delenv("LANTERN_NO_PROGRAM_CACHE", raising=False)
    from lantern.engine import color
    color._built_processor.cache_clear()
    yield tmp_path
    color._built_processor.cache_clear()


def hdr_image():
    rng = np.random.default_rng(3)
    return (rng.random((32, 32, 3)) ** 3 * 40.0).astype(np.float32)


def entries(folder):
    return sorted(p.name for p in folder.glob("colour-*.npz"))


@pytest.mark.parametrize("view,look", [("AgX", None), ("Filmic", None),
                                       ("Khronos PBR Neutral", None), ("Filmic Log", None)])
def test_a_stored_transform_maps_an_image_as_the_config_does(cache, view, look):
    from lantern.engine import color
    first = color.display_rgb(hdr_image(), view, look, 0.5)      # built, then stored
    assert len(entries(cache)) == 1
    color._built_processor.cache_clear()
    again = color.display_rgb(hdr_image(), view, look, 0.5)      # from the entry
    assert np.array_equal(first, again)


def test_what_comes_from_the_entry_is_not_the_configs_build(cache, monkeypatch):
    """The second build reads the entry: the config's processor is not asked for again."""
    from lantern.engine import color
    color.display_rgb(hdr_image(), "AgX")
    color._built_processor.cache_clear()
    config = color._config()
    asked = []
    real = type(config).getProcessor

    class Counting:
        def __getattr__(self, name):
            return getattr(config, name)

        def getProcessor(self, transform):
            asked.append(type(transform).__name__)
            return real(config, transform)
    monkeypatch.setattr(color, "_config", lambda: Counting())
    color.display_rgb(hdr_image(), "AgX")
    assert len(asked) == 1                  # the stored ops' group: no second build


def test_a_damaged_entry_is_built_again_and_rewritten(cache):
    from lantern.engine import color
    first = color.display_rgb(hdr_image(), "AgX")
    (entry,) = cache.glob("colour-*.npz")
    entry.write_bytes(entry.read_bytes()[:1000])
    color._built_processor.cache_clear()
    again = color.display_rgb(hdr_image(), "AgX")
    assert np.array_equal(first, again)
    assert entry.stat().st_size > 1000


def test_an_op_this_module_does_not_know_is_not_stored(cache):
    """ACES 1.3's view holds a GradingRGBCurveTransform, AgX's Punchy look a
    GradingPrimaryTransform."""
    from lantern.engine import color
    color.display_rgb(hdr_image(), "ACES 1.3")
    color.display_rgb(hdr_image(), "AgX", "Punchy")
    assert entries(cache) == []


def test_ops_read_back_wrong_are_not_stored(cache, monkeypatch):
    """A parameter lost on the way (the LUT's tetrahedral interpolation) changes the
    colours: nothing stored."""
    from lantern.engine import color, color_cache
    monkeypatch.setitem(color_cache._OPS, "Lut3DTransform",
                        [op for op in color_cache._OPS["Lut3DTransform"]
                         if op[0] != "getInterpolation"])
    first = color.display_rgb(hdr_image(), "AgX")
    assert entries(cache) == []
    color._built_processor.cache_clear()
    monkeypatch.undo()
    assert np.array_equal(first, color.display_rgb(hdr_image(), "AgX"))


def test_the_cache_turned_off_stores_nothing(cache, monkeypatch):
    from lantern.engine import color
    monkeypatch.setenv("LANTERN_NO_PROGRAM_CACHE", "1")
    color.display_rgb(hdr_image(), "AgX")
    assert entries(cache) == []


def test_the_entrys_name_follows_the_configs_files(tmp_path):
    """A LUT file changed beside the config names another entry; the same files the same."""
    import PyOpenColorIO as ocio
    from lantern.engine import color, color_cache
    source = os.path.dirname(color.config_path())
    folder = tmp_path / "colormanagement"
    shutil.copytree(source, folder)
    path = str(folder / "config.ocio")
    config = ocio.Config.CreateFromFile(path)
    names = ("AgX", "", 0.0)
    before = color_cache.key(config, path, names)
    assert color_cache.key(config, path, names) == before
    assert color_cache.key(config, path, ("AgX", "", 0.5)) != before
    lut = folder / "luts" / "AgX_Base_sRGB.cube"
    stat = lut.stat()
    os.utime(lut, ns=(stat.st_atime_ns, stat.st_mtime_ns + 10**9))
    assert color_cache.key(config, path, names) != before


def test_the_folder_keeps_the_entries_used_last(cache, monkeypatch):
    """Each exposure is an entry of its own (2 MB with AgX): the folder keeps KEEP, those
    used last, and reading an entry uses it."""
    from lantern.engine import color, color_cache
    monkeypatch.setattr(color_cache, "KEEP", 2)

    def entry(exposure):
        name = color_cache.key(color._config(), color.config_path(), ("AgX", "", exposure))
        return cache / f"colour-{name}.npz"
    for exposure in (0.0, 1.0):
        color.display_rgb(hdr_image(), "AgX", None, exposure)
    os.utime(entry(0.0), ns=(1, 1))                      # the older of the two ...
    os.utime(entry(1.0), ns=(2, 2))
    color._built_processor.cache_clear()
    color.display_rgb(hdr_image(), "AgX", None, 0.0)     # ... read again: used now
    color.display_rgb(hdr_image(), "AgX", None, 2.0)     # a third: the least used goes
    assert entries(cache) == sorted([entry(0.0).name, entry(2.0).name])


def test_an_entry_in_a_folder_this_process_may_only_read_is_used(cache, monkeypatch):
    """Marking an entry used can fail (a shared cache mounted read-only): it is read all
    the same."""
    from lantern.engine import color, color_cache
    first = color.display_rgb(hdr_image(), "AgX")
    color._built_processor.cache_clear()

    def read_only(*args, **kwargs):
        raise PermissionError("read-only file system")
    monkeypatch.setattr(color_cache.os, "utime", read_only)
    built = []
    monkeypatch.setattr(color_cache, "store", lambda *a: built.append(a) or False)
    assert np.array_equal(first, color.display_rgb(hdr_image(), "AgX"))
    assert built == []                   # read from the entry, not built again
