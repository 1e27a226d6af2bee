"""Display transforms kept in Lantern's cache folder (core/cache_folder.py): the ops an
OpenColorIO processor resolves a view, look and exposure to (matrices, logs, curves,
LUT samples), stored so that a new process builds the same processor without parsing
the config's LUT files again. Parsing them is most of a cold `lantern render`'s
colour management: AgX's 57^3 .cube is 2.7 MB of text, about 120 ms a process.

An entry is named by the sha256 of the OpenColorIO version, the transform's names and
exposure, the config file's bytes and the size and time of every file in its search
path. It is stored only when the processor rebuilt from it gives the same values as
the one built from the config on PROBE colours (so a kind of op read wrongly, or one
this module does not know, is never stored: those transforms are built from the
config each time). An entry that cannot be read is built again and rewritten, said
only at debug level; a folder that cannot be written costs the speed-up."""
from __future__ import annotations

import hashlib
import io
import json
import logging
import os

import numpy as np

from ..core import cache_folder
from ..core.files import atomic_write_bytes

log = logging.getLogger(__name__)

FORMAT = 1
KEEP = 16                    # entries kept in the folder, those used last
# Colours the rebuilt processor must map exactly as the config's: a grey ramp over the
# range a render holds (negative, 0, 1e-6 to 1e4) and pseudo-random colours over it.
_RAMP = np.concatenate([[-1.0, 0.0], np.geomspace(1e-6, 1e4, 190)])
PROBE = np.concatenate([np.repeat(_RAMP[:, None], 3, 1),
                        np.random.default_rng(7).choice(_RAMP, (4096, 3))]).astype(np.float32)


# Per kind of op: its parameters (getter, setter, kind of value): "a" an array, "e" an
# enum, "f" a number, "b" a flag. Direction is every op's.
_OPS = {
    "MatrixTransform": [("getMatrix", "setMatrix", "a"), ("getOffset", "setOffset", "a")],
    "LogTransform": [("getBase", "setBase", "f")],
    "ExponentTransform": [("getValue", "setValue", "a"),
                          ("getNegativeStyle", "setNegativeStyle", "e")],
    "ExponentWithLinearTransform": [("getGamma", "setGamma", "a"),
                                    ("getOffset", "setOffset", "a"),
                                    ("getNegativeStyle", "setNegativeStyle", "e")],
    "Lut1DTransform": [("getLength", "setLength", "f"), ("getData", "setData", "a"),
                       ("getInterpolation", "setInterpolation", "e"),
                       ("getInputHalfDomain", "setInputHalfDomain", "b"),
                       ("getOutputRawHalfs", "setOutputRawHalfs", "b"),
                       ("getHueAdjust", "setHueAdjust", "e")],
    "Lut3DTransform": [("getGridSize", "setGridSize", "f"), ("getData", "setData", "a"),
                       ("getInterpolation", "setInterpolation", "e")],
    "RangeTransform": [("getStyle", "setStyle", "e"),
                       ("getMinInValue", "setMinInValue", "f"),
                       ("getMaxInValue", "setMaxInValue", "f"),
                       ("getMinOutValue", "setMinOutValue", "f"),
                       ("getMaxOutValue", "setMaxOutValue", "f")],
    "FixedFunctionTransform": [("getStyle", "setStyle", "e"), ("getParams", "setParams", "a")],
}
# A range's bounds may be unset (no clamp on that side): kept as None, set only where set.
_RANGE_HAS = {"getMinInValue": "hasMinInValue", "getMaxInValue": "hasMaxInValue",
              "getMinOutValue": "hasMinOutValue", "getMaxOutValue": "hasMaxOutValue"}


def kept(config, config_path: str, names: tuple, transform):
    """The processor of `config` for `names` (view, look, exposure): the one stored by an
    earlier process, else the config's for `transform()` (a Transform), stored for the
    next."""
    if cache_folder.disabled():
        return config.getProcessor(transform())
    name = key(config, config_path, names)
    processor = stored(config, name)
    if processor is None:
        processor = config.getProcessor(transform())
        store(config, name, processor)
    return processor


def key(config, config_path: str, names: tuple) -> str:
    """The entry's name for the transform `names` (view, look, exposure) of `config`."""
    import PyOpenColorIO as ocio
    h = hashlib.sha256(json.dumps([FORMAT, ocio.__version__, list(map(str, names))]).encode())
    with open(config_path, "rb") as f:
        h.update(f.read())
    folder = os.path.dirname(os.path.abspath(config_path))
    for entry in sorted(config.getSearchPath().split(":")):
        where = entry if os.path.isabs(entry) else os.path.join(folder, entry)
        for name in sorted(os.listdir(where)) if os.path.isdir(where) else ():
            stat = os.stat(os.path.join(where, name))
            h.update(f"{entry}/{name}:{stat.st_size}:{stat.st_mtime_ns}\n".encode())
    return h.hexdigest()


def _path(name: str) -> str:
    return os.path.join(cache_folder.cache_folder(), f"colour-{name}.npz")


def stored(config, name: str):
    """The processor stored as `name`, or None where there is none (or it cannot be
    read: logged at debug level)."""
    path = _path(name)
    try:
        os.utime(path)               # used now: pruning keeps it
    except FileNotFoundError:
        return None
    except OSError:                  # a folder this process may only read: used as it is
        pass
    try:
        with np.load(path, allow_pickle=False) as entry:
            ops = json.loads(str(entry["ops"]))
            arrays = {k: entry[k] for k in entry.files if k != "ops"}
        return config.getProcessor(_group(ops, arrays))
    except FileNotFoundError:
        return None
    except Exception as error:     # noqa: BLE001  (a damaged entry: built again)
        log.debug("colour cache: %s cannot be read (%s); building it again", path, error)
        return None


def store(config, name: str, processor) -> bool:
    """Keeps `processor` as `name` if its ops are all of _OPS's kinds and the processor
    rebuilt from them maps PROBE as it does; False where it is not kept."""
    try:
        return _store(config, name, processor)
    except Exception as error:     # noqa: BLE001  (the cache never costs a render)
        log.debug("colour cache: %s not kept (%s)", name, error)
        return False


def _store(config, name, processor):
    ops, arrays = [], {}
    for op in processor.createGroupTransform():
        kind = type(op).__name__
        if kind not in _OPS:
            log.debug("colour cache: a %s op is not kept; built from the config", kind)
            return False
        params = {"direction": int(op.getDirection())}
        for getter, _, sort in _OPS[kind]:
            if kind == "RangeTransform" and getter in _RANGE_HAS and \
                    not getattr(op, _RANGE_HAS[getter])():
                params[getter] = None
                continue
            value = getattr(op, getter)()
            if sort == "a":
                arrays[f"{len(ops)}.{getter}"] = np.asarray(value)
            else:
                params[getter] = int(value) if sort == "e" else \
                    bool(value) if sort == "b" else float(value)
        ops.append([kind, params])
    rebuilt = config.getProcessor(_group(ops, arrays))
    if not np.array_equal(_mapped(processor), _mapped(rebuilt), equal_nan=True):
        log.debug("colour cache: the stored form of %s maps colours differently; not kept",
                  name)
        return False
    buffer = io.BytesIO()
    np.savez(buffer, ops=np.array(json.dumps(ops)), **arrays)
    try:
        os.makedirs(cache_folder.cache_folder(), exist_ok=True)
        atomic_write_bytes(_path(name), buffer.getvalue(), suffix=".npz")
        _prune()
    except OSError as error:
        log.debug("colour cache: %s cannot be written (%s)", _path(name), error)
        return False
    return True


def _prune():
    """Keeps the KEEP entries used last (an entry is 2 MB with AgX's LUT, and each
    exposure is an entry of its own): the others are removed."""
    folder = cache_folder.cache_folder()
    entries = []
    for name in os.listdir(folder):
        if name.startswith("colour-") and name.endswith(".npz"):
            try:
                entries.append((os.stat(os.path.join(folder, name)).st_mtime_ns, name))
            except FileNotFoundError:        # another process pruned it meanwhile
                pass
    for _, name in sorted(entries)[:-KEEP]:
        try:
            os.remove(os.path.join(folder, name))
        except FileNotFoundError:
            pass


def _mapped(processor) -> np.ndarray:
    pixels = PROBE.copy()
    processor.getDefaultCPUProcessor().applyRGB(pixels)
    return pixels


def _group(ops, arrays):
    """The GroupTransform of stored `ops` (kind, parameters) and their `arrays`."""
    import PyOpenColorIO as ocio
    group = ocio.GroupTransform()
    for index, (kind, params) in enumerate(ops):
        if kind == "FixedFunctionTransform":     # its style and parameters checked as one
            op = ocio.FixedFunctionTransform(ocio.FixedFunctionStyle(params["getStyle"]),
                                             list(arrays[f"{index}.getParams"]))
        else:
            op = getattr(ocio, kind)()
        setters = {getter: (setter, sort) for getter, setter, sort in _OPS[kind]}
        # A LUT's size first: setting its samples checks them against it.
        for getter in sorted(setters, key=lambda g: g not in ("getLength", "getGridSize")):
            setter, sort = setters[getter]
            if sort == "a":
                value = arrays[f"{index}.{getter}"]
            else:
                value = params[getter]
                if value is None:          # a range's side left unset
                    continue
                if sort == "e":
                    value = _enum_of(op, getter, value)
                elif getter in ("getLength", "getGridSize"):
                    value = int(value)
            getattr(op, setter)(value)
        op.setDirection(ocio.TransformDirection(params["direction"]))
        group.appendTransform(op)
    return group


def _enum_of(op, getter, number):
    """The enum value `number` of the type `getter` returns."""
    return type(getattr(op, getter)())(number)
