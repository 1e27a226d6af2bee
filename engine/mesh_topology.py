"""How a triangle mesh's faces join, asked by the emitters (a closed mesh's inside is
lit by its back faces alone: engine/emitters.py) and by the bounce's test of whether
surfaces light each other (a closed convex solid's faces see only its outside:
engine/bounces.py)."""
from __future__ import annotations

import numpy as np


def closed(mesh) -> bool:
    """Whether a mesh's triangles close a volume: each edge (between points of equal
    position: a cube's faces may have points of their own) shared by exactly two."""
    _, point = np.unique(mesh.vertices[:, :3], axis=0, return_inverse=True)
    tris = point.reshape(-1)[mesh.indices].reshape(-1, 3)
    edges = np.sort(np.concatenate([tris[:, [0, 1]], tris[:, [1, 2]], tris[:, [2, 0]]]), axis=1)
    _, counts = np.unique(edges, axis=0, return_counts=True)
    return len(counts) > 0 and bool(np.all(counts == 2))
