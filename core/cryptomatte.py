"""Cryptomatte ids and metadata, as the specification says (Psyop, version 1.2.0,
github.com/Psyop/Cryptomatte `specification/`):

- a name (UTF-8 bytes) is hashed with MurmurHash3_x86_32, seed 0;
- the 32-bit hash becomes a float32 bit for bit, its exponent kept within 1..254 so
  that no id is 0, a denormal, an infinity or a NaN ("uint32_to_float32");
- each kind of matte (object, material, asset) has a layer name, e.g.
  `ViewLayer.CryptoObject`, with numbered RGBA layers `ViewLayer.CryptoObject00`, ...
  holding (id, coverage) pairs by rank; its metadata lives under
  `cryptomatte/<key>/` with `key` the first 7 hex digits of the layer name's hash:
  `name`, `hash` (MurmurHash3_32), `conversion` (uint32_to_float32) and `manifest`, a
  JSON object {name: the id's float bits as 8 hex digits}.

Pure Python: the engine hashes names here for its id pass and the image writer
writes the metadata from here."""
from __future__ import annotations

import functools
import json
import struct

HASH = "MurmurHash3_32"
CONVERSION = "uint32_to_float32"


def murmur3_32(data: bytes, seed: int = 0) -> int:
    """MurmurHash3_x86_32 of `data`, as an unsigned 32-bit integer."""
    c1, c2, mask = 0xCC9E2D51, 0x1B873593, 0xFFFFFFFF
    h = seed & mask
    n = len(data) // 4 * 4
    for (k,) in struct.iter_unpack("<I", data[:n]):
        k = (k * c1) & mask
        k = ((k << 15) | (k >> 17)) & mask
        h ^= (k * c2) & mask
        h = ((h << 13) | (h >> 19)) & mask
        h = (h * 5 + 0xE6546B64) & mask
    tail = data[n:]
    if tail:
        k = int.from_bytes(tail, "little")
        k = (k * c1) & mask
        k = ((k << 15) | (k >> 17)) & mask
        h ^= (k * c2) & mask
    h ^= len(data)
    h ^= h >> 16
    h = (h * 0x85EBCA6B) & mask
    h ^= h >> 13
    h = (h * 0xC2B2AE35) & mask
    h ^= h >> 16
    return h


def _float_bits(h: int) -> int:
    """The hash with its float exponent moved off 0 and 255 (the specification's
    conversion: flip the exponent's lowest bit)."""
    exponent = (h >> 23) & 0xFF
    return h ^ (1 << 23) if exponent in (0, 255) else h


@functools.lru_cache(maxsize=65536)
def name_id(name: str) -> float:
    """The float32 id of `name` (a Python float holding a float32 exactly)."""
    bits = _float_bits(murmur3_32(name.encode("utf-8")))
    return struct.unpack("<f", struct.pack("<I", bits))[0]


def id_hex(name: str) -> str:
    """The manifest's text for `name`'s id: its float bits as 8 hex digits."""
    return f"{_float_bits(murmur3_32(name.encode('utf-8'))):08x}"


def layer_key(layer: str) -> str:
    """The metadata key of a matte layer (`ViewLayer.CryptoObject`): its name's hash,
    first 7 hex digits (as Blender and the specification suggest)."""
    return f"{murmur3_32(layer.encode('utf-8')):08x}"[:7]


def metadata(layer: str, manifest: dict) -> dict:
    """{attribute: value} of one matte layer's header metadata; `manifest`: {name: id
    as 8 hex digits} (id_hex)."""
    prefix = f"cryptomatte/{layer_key(layer)}/"
    manifest = json.dumps(dict(sorted(manifest.items())), separators=(",", ":"),
                          ensure_ascii=False)
    return {prefix + "name": layer, prefix + "hash": HASH,
            prefix + "conversion": CONVERSION, prefix + "manifest": manifest}
