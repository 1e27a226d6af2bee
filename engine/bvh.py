"""Bounding volume hierarchies for the ray tracer (engine/gpu/raytracer.py,
shaders/raytrace.glsl): one binary tree over a set of boxes, built as Karras 2012
builds a linear BVH and refitted when the boxes move.

Build: the boxes' centres get Morton codes over their union (core/morton.py), made
unique by the box's index in their low 32 bits, and sorted. The root holds the whole
sorted range; a range splits where its keys' highest differing bit turns from 0 to 1
(one binary search: np.searchsorted), so each node's children follow from its range
alone and a level of the tree is one vectorised step. One box per leaf.

Layout: depth first (preorder). A node's left child is the next node, its right child
follows the left's subtree, and `miss` is the node after its own subtree (a subtree
over k boxes holds 2k - 1 nodes): a ray that misses a node's box goes to `miss`, one
that enters goes to the next node, so the GPU walks the tree without a stack, one
iteration a node (llvmpipe ends an invocation's loops after 65,535 iterations,
docs/status.md), and a two-level walk is one loop.

Refit: the leaves take their boxes' new bounds, then each inner node, by height from
the leaves up, the union of its two children (several trees at once: one numpy pass a
height over all of them); the order (and so the tree's quality) stays the build's.
The tree stays exact: every node bounds its boxes, whatever moved."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..core.morton import morton_codes

NODE_FLOATS = 8              # lo.xyz, miss; hi.xyz, box index (-1: inner): shaders/raytrace.glsl


@dataclass
class Tree:
    """A built tree of n boxes: 2n - 1 nodes in preorder. lo, hi (nodes, 3) float32;
    miss (nodes,) the node after each one's subtree; prim (nodes,) a leaf's box index,
    -1 for an inner node; right (nodes,) an inner node's right child (-1 for a leaf);
    heights: the inner nodes by height (1: over leaves only), the refit's order, in
    which several trees are refitted together (refit_many)."""
    lo: np.ndarray
    hi: np.ndarray
    miss: np.ndarray
    prim: np.ndarray
    right: np.ndarray
    heights: list
    _leaves: np.ndarray | None = None

    @property
    def leaves(self) -> np.ndarray:
        """The leaf nodes' indices."""
        if self._leaves is None:
            self._leaves = np.nonzero(self.prim >= 0)[0]
        return self._leaves

    @property
    def size(self) -> int:
        return len(self.miss)

    def packed(self, node_offset: int = 0, prim_offset: int = 0) -> np.ndarray:
        """(nodes, NODE_FLOATS) float32 as the shader reads them, its node and box
        indices shifted by the offsets of the buffers it is placed in."""
        out = np.empty((self.size, NODE_FLOATS), np.float32)
        out[:, 0:3], out[:, 4:7] = self.lo, self.hi
        out[:, 3] = (self.miss + node_offset).astype(np.int32).view(np.float32)
        prim = np.where(self.prim >= 0, self.prim + prim_offset, -1)
        out[:, 7] = prim.astype(np.int32).view(np.float32)
        return out


def build(lo: np.ndarray, hi: np.ndarray) -> Tree:
    """The tree over boxes (lo, hi) (n, 3), n >= 1."""
    lo, hi = np.asarray(lo, np.float64), np.asarray(hi, np.float64)
    n = len(lo)
    if n == 0:
        raise ValueError("a BVH needs at least one box")
    centre = 0.5 * (lo + hi)
    code = morton_codes(centre, centre.min(axis=0), centre.max(axis=0))
    keys = (code << np.uint64(32)) | np.arange(n, dtype=np.uint64)
    keys.sort()
    order = (keys & np.uint64(0xFFFFFFFF)).astype(np.int64)

    size = 2 * n - 1
    miss = np.empty(size, np.int64)
    prim = np.full(size, -1, np.int64)
    right = np.full(size, -1, np.int64)
    levels = []
    node, first, last = np.zeros(1, np.int64), np.zeros(1, np.int64), np.full(1, n - 1)
    while len(node):
        count = last - first + 1
        miss[node] = node + 2 * count - 1
        leaf = count == 1
        prim[node[leaf]] = order[first[leaf]]
        node, first, last = node[~leaf], first[~leaf], last[~leaf]
        if not len(node):
            break
        levels.append(node)
        split = _split(keys, first, last)
        right[node] = node + 2 * (split - first + 1)
        node = np.concatenate([node + 1, right[node]])
        first, last = np.concatenate([first, split + 1]), np.concatenate([split, last])
    height = np.zeros(size, np.int64)
    for node in levels[::-1]:                       # deepest first
        height[node] = np.maximum(height[node + 1], height[right[node]]) + 1
    inner = np.nonzero(prim < 0)[0]
    by_height = inner[np.argsort(height[inner], kind="stable")]
    cuts = np.searchsorted(height[by_height], np.arange(1, height.max() + 1), side="right")
    tree = Tree(np.zeros((size, 3), np.float32), np.zeros((size, 3), np.float32),
                miss, prim, right, np.split(by_height, cuts)[:-1])
    refit(tree, lo, hi)
    return tree


def _split(keys, first, last) -> np.ndarray:
    """The last index of each range [first, last] whose key has a 0 at the highest bit
    where the range's first and last keys differ (Karras's split)."""
    diff = keys[first] ^ keys[last]
    upper, lower = diff >> np.uint64(32), diff & np.uint64(0xFFFFFFFF)
    # frexp is exact on integers below 2^53: x = m 2^e with m in [0.5, 1).
    bit = np.where(upper > 0, np.frexp(upper.astype(np.float64))[1] + 31,
                   np.frexp(lower.astype(np.float64))[1] - 1).astype(np.uint64)
    boundary = ((keys[first] >> bit) | np.uint64(1)) << bit
    return np.searchsorted(keys, boundary, side="left") - 1


def refit(tree: Tree, lo: np.ndarray, hi: np.ndarray):
    """The tree's boxes again from its boxes' new bounds (lo, hi) (n, 3), in place.
    Bounds are rounded outwards to float32, so a node never shrinks below its boxes."""
    refit_many([tree], [0], tree.lo, tree.hi, [lo], [hi])


def refit_many(trees, offsets, node_lo, node_hi, lo, hi):
    """Several trees refitted at once, in place: their nodes lie in node_lo, node_hi
    (N, 3) float32 from `offsets`, and lo[i], hi[i] are tree i's boxes' new bounds.
    One numpy pass a height over all of them, not one a level of each."""
    at = np.concatenate([off + t.leaves for off, t in zip(offsets, trees)])
    node_lo[at] = _outward(np.concatenate([np.asarray(b)[t.prim[t.leaves]]
                                           for b, t in zip(lo, trees)]), -np.inf)
    node_hi[at] = _outward(np.concatenate([np.asarray(b)[t.prim[t.leaves]]
                                           for b, t in zip(hi, trees)]), np.inf)
    for h in range(max(len(t.heights) for t in trees)):
        level = [(off + t.heights[h], off + t.right[t.heights[h]])
                 for off, t in zip(offsets, trees) if h < len(t.heights)]
        node = np.concatenate([n for n, _ in level])
        r = np.concatenate([r for _, r in level])
        node_lo[node] = np.minimum(node_lo[node + 1], node_lo[r])
        node_hi[node] = np.maximum(node_hi[node + 1], node_hi[r])


def _outward(values: np.ndarray, towards: float) -> np.ndarray:
    """float32 values not inside `values`: rounded towards `towards` (float32 values
    are their own)."""
    values = np.asarray(values)
    if values.dtype == np.float32:
        return values
    f = values.astype(np.float32)
    inside = f > values if towards < 0 else f < values
    return np.where(inside, np.nextafter(f, np.float32(towards)), f)


def triangle_boxes(triangles: np.ndarray):
    """(lo, hi) (T, 3) of triangles (T, 3, 3), in their own precision (corner by
    corner: numpy's reduction over a 3-long middle axis is many times slower)."""
    a, b, c = triangles[:, 0], triangles[:, 1], triangles[:, 2]
    return np.minimum(np.minimum(a, b), c), np.maximum(np.maximum(a, b), c)
