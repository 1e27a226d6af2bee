"""What the Cryptomatte mattes name (core/cryptomatte.py hashes the names): prim paths.

  CryptoObject    the drawn prim: a Mesh or Points prim; a PointInstancer's instances
                  take the instancer's path (they have no prim of their own)
  CryptoMaterial  the bound Material prim (the engine's material name)
  CryptoAsset     the asset the prim belongs to (engine/usd/read.py asset_path)

The id pass (engine/gpu/passes/cryptomatte.py) and the manifest written beside the
image both take their names from here."""
from __future__ import annotations

from ..core.cryptomatte import id_hex
from ..core.passes import PASSES


def object_name(path: str) -> str:
    """The object matte's name of a drawn record (an instance batch's key is
    `<instancer>{<mesh>}`)."""
    return path.split("{", 1)[0]


def names(scene, matte: str) -> list:
    """The names one matte (CryptoObject, CryptoMaterial, CryptoAsset) holds for this
    scene, sorted."""
    drawn = list(scene.instances.values()) + list(scene.points.values())
    if matte == "CryptoObject":
        found = {object_name(r.path) for r in drawn}
    elif matte == "CryptoAsset":
        found = {r.asset for r in drawn}
    elif matte == "CryptoMaterial":
        found = set(scene.materials)
    else:
        raise ValueError(f"unknown Cryptomatte {matte!r}")
    return sorted(found)


def manifests(scene, passes) -> dict:
    """{matte: {name: id as 8 hex digits}} of the mattes among `passes`."""
    mattes = dict.fromkeys(PASSES[n].matte for n in sorted(passes) if PASSES[n].matte)
    return {m: {name: id_hex(name) for name in names(scene, m)} for m in mattes}
