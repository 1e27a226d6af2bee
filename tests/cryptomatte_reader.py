"""A Cryptomatte decoder written from the specification's text (Psyop, version 1.2.0,
github.com/Psyop/Cryptomatte `specification/cryptomatte_specification.pdf`), not from
Lantern's writer, for the tests:

- the header holds, per matte type, `cryptomatte/<key>/name` (the type's name, which
  is the layer name), `.../hash`, `.../conversion` and optionally `.../manifest`, a
  JSON dictionary of names to 8 hex digits, the float id's bits;
- the layers `<name>00`, `<name>01`, ... hold in .r and .b an id, in .g and .a its
  coverage (rank 0 in 00.r/00.g, rank 1 in 00.b/00.a, rank 2 in 01.r/01.g, ...);
- a name's matte is the sum of the coverages of its id over the ranks.

Read with OpenImageIO, from every part of the file."""
import json
import struct

import numpy as np


def read(path):
    """(header attributes {name: value}, channels {channel name: float32 (H, W)}) of an
    EXR, all parts together; row 0 = top."""
    import OpenImageIO as oiio
    image = oiio.ImageInput.open(str(path))
    if image is None:
        raise OSError(f"{path}: {oiio.geterror()}")
    header, channels = {}, {}
    try:
        part = 0
        while image.seek_subimage(part, 0):
            spec = image.spec()
            for attribute in spec.extra_attribs:
                header.setdefault(attribute.name, attribute.value)
            pixels = np.asarray(image.read_image(part, 0, 0, spec.nchannels, "float"),
                                np.float32).reshape(spec.height, spec.width, spec.nchannels)
            for k, name in enumerate(spec.channelnames):
                channels[name] = pixels[..., k]
            part += 1
    finally:
        image.close()
    return header, channels


def matte_types(header) -> dict:
    """{type name: {name: float id}} from the metadata, as the specification lays it
    out (hash and conversion checked)."""
    types = {}
    for key in {k.split("/")[1] for k in header if k.startswith("cryptomatte/")}:
        prefix = f"cryptomatte/{key}/"
        assert header[prefix + "hash"] == "MurmurHash3_32", header
        assert header[prefix + "conversion"] == "uint32_to_float32", header
        manifest = json.loads(header.get(prefix + "manifest", "{}"))
        types[header[prefix + "name"]] = {
            name: struct.unpack(">f", bytes.fromhex(digits))[0]
            for name, digits in manifest.items()}
    return types


def ranks(channels, type_name) -> list:
    """[(ids, coverages)] of every rank of a matte type, in rank order."""
    out, level = [], 0
    while f"{type_name}{level:02d}.r" in channels:
        layer = f"{type_name}{level:02d}"
        out.append((channels[layer + ".r"], channels[layer + ".g"]))
        out.append((channels[layer + ".b"], channels[layer + ".a"]))
        level += 1
    return out


def coverage(channels, type_name, float_id) -> np.ndarray:
    """One id's matte: its coverage summed over the ranks."""
    return sum(np.where(ids == np.float32(float_id), cov, 0.0)
               for ids, cov in ranks(channels, type_name))
