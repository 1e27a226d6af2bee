"""Relative shape keys -> BlendShapeRecords, and their weights over time.

Blender adds, for every key but the reference key, value · mask · (key − its relative
key), where mask is the key's vertex group weight (1 without one). That is exactly a
UsdSkel blend shape whose offsets are the masked difference, baked per key here.
"""
import numpy as np

from ..ir import BlendShapeRecord
from .skin import group_entries


def _co(key_block):
    out = np.empty(len(key_block.data) * 3, dtype=np.float32)
    key_block.data.foreach_get("co", out)
    return out.reshape(-1, 3).astype(np.float64)


def _group_weights(ob, mesh, name):
    group = ob.vertex_groups.get(name)
    weights = np.zeros(len(mesh.vertices))
    if group is None:
        return weights
    vertex, groups, w = group_entries(mesh)
    keep = groups == group.index
    weights[vertex[keep]] = w[keep]
    return weights


def shape_keys(ob):
    """Key blocks that become blend shapes: all but the reference key, in order."""
    key = ob.data.shape_keys
    return [kb for kb in key.key_blocks if kb != key.reference_key]


def gather_blend_shapes(ob):
    mesh = ob.data
    blocks = {kb.name: _co(kb) for kb in mesh.shape_keys.key_blocks}
    shapes = []
    for kb in shape_keys(ob):
        offsets = blocks[kb.name] - blocks[kb.relative_key.name]
        if kb.vertex_group:
            offsets *= _group_weights(ob, mesh, kb.vertex_group)[:, None]
        moved = np.flatnonzero(np.abs(offsets).max(axis=1) > 0).astype(np.int32)
        shapes.append(BlendShapeRecord(name=kb.name, offsets=offsets[moved].astype(np.float32),
                                       indices=moved))
    return shapes


def shape_weights(ob_eval, names):
    """Current values of the named keys on the evaluated object (muted keys weigh 0)."""
    blocks = ob_eval.data.shape_keys.key_blocks
    return [0.0 if blocks[n].mute else float(blocks[n].value) for n in names]
