"""A material's MaterialX-style pattern network (outputs:mtlx:surface, an
ND_UsdPreviewSurface_surfaceshader fed by nodes whose lantern:nodeDef is
ND_lantern_<kind>) -> PatternGraph.

Only the surface's connected inputs are read here; its constants and textures are the
UsdPreviewSurface's (materials.py). A node whose id or setting is not Lantern's, a
value that is not finite, or a link to a missing prim is a warning naming the material
and the node, and that surface input keeps its UsdPreviewSurface value."""
from __future__ import annotations

import os

import numpy as np
from pxr import Sdf, UsdShade

from ...core.images import filtertype_of
from ...core.pattern_nodes import SURFACE_INPUTS, unsupported_setting
from ..scene import PatternGraph, PatternNode

MTLX_SURFACE = "ND_UsdPreviewSurface_surfaceshader"
PREFIX = "ND_lantern_"
NODE_DEF = "lantern:nodeDef"   # a node's definition (docs/stage_contract.md), else info:id
TYPES = {Sdf.ValueTypeNames.Float: "float", Sdf.ValueTypeNames.Vector3f: "vector",
         Sdf.ValueTypeNames.Color3f: "color", Sdf.ValueTypeNames.Float3: "vector",
         Sdf.ValueTypeNames.FloatArray: "float[]", Sdf.ValueTypeNames.Color4fArray: "color4[]"}


class _Bad(Exception):
    pass


def _value(typ, value):
    if typ == "float":
        return float(value)
    if typ == "float[]":
        return tuple(float(v) for v in value)
    if typ == "color4[]":
        return tuple(tuple(float(c) for c in v) for v in value)
    return tuple(float(c) for c in value)


def _producer(inp):
    """(shader, output name, output type) feeding `inp` through node-graph outputs, or None."""
    for attr in inp.GetValueProducingAttributes():
        if UsdShade.Output.IsOutput(attr):
            return UsdShade.Shader(attr.GetPrim()), attr.GetBaseName(), \
                TYPES.get(attr.GetTypeName(), "float")
    return None


def read_pattern(mat: UsdShade.Material, time, warnings: list) -> PatternGraph | None:
    out = mat.GetSurfaceOutput("mtlx")
    if not out:
        return None
    attrs = out.GetValueProducingAttributes()
    surface = UsdShade.Shader(attrs[0].GetPrim()) if attrs else None
    if not surface or str(surface.GetIdAttr().Get() or "") != MTLX_SURFACE:
        return None
    path = str(mat.GetPath())
    nodes, outputs = {}, []

    def node(shader):
        name = str(shader.GetPath())
        if name in nodes:
            return name
        node_def = shader.GetPrim().GetAttribute(NODE_DEF)
        ident = str((node_def.Get() if node_def else None) or shader.GetIdAttr().Get() or "")
        if not ident.startswith(PREFIX):
            raise _Bad(f"{path}: node {name} ({ident or 'no id'}) is not supported")
        nodes[name] = None                       # a cycle reads as a missing node
        settings, values, links = [], [], []
        for inp in shader.GetInputs():
            base = inp.GetBaseName()
            typ = TYPES.get(inp.GetTypeName())
            if inp.GetTypeName() == Sdf.ValueTypeNames.String:
                settings.append((base, str(inp.Get(time))))
                continue
            if inp.GetTypeName() == Sdf.ValueTypeNames.Asset:
                asset = inp.Get(time)
                resolved = asset.resolvedPath if asset is not None else ""
                if not resolved or not os.path.isfile(resolved):
                    raise _Bad(f"{path}: texture file {asset.path if asset else ''!r} of {name} "
                               f"not found")
                values.append((base, "asset", resolved))
                continue
            if typ is None:
                raise _Bad(f"{path}: input {base} of {name} has type {inp.GetTypeName()}")
            if inp.GetAttr().HasAuthoredConnections():
                src = _producer(inp)
                if src is None:
                    raise _Bad(f"{path}: input {base} of {name} is connected to a missing prim")
                src_name = node(src[0])
                if nodes.get(src_name) is None:
                    raise _Bad(f"{path}: {name} is in a cycle")
                links.append((base, typ, src_name, src[1], src[2]))
            else:
                value = _value(typ, inp.Get(time))
                if not np.all(np.isfinite(np.asarray(value, np.float64))):
                    raise _Bad(f"{path}: input {base} of {name} is not finite ({value})")
                values.append((base, typ, value))
        if ident == PREFIX + "image":          # an unknown interpolation reads as Linear
            settings = [(k, filtertype_of(v, name, warnings.append) if k == "filtertype" else v)
                        for k, v in settings]
        why = unsupported_setting(ident[len(PREFIX):], dict(settings))
        if why is not None:
            raise _Bad(f"{path}: node {name}: {why}")
        nodes[name] = PatternNode(name=name, kind=ident[len(PREFIX):],
                                  settings=tuple(sorted(settings)), values=tuple(sorted(values)),
                                  links=tuple(sorted(links)))
        return name

    for target in SURFACE_INPUTS:
        inp = surface.GetInput(target)
        if not inp or not inp.GetAttr().HasAuthoredConnections():
            continue
        src = _producer(inp)
        if src is None:
            warnings.append(f"{path}: mtlx input {target} is connected to a missing prim; "
                            f"using the UsdPreviewSurface value")
            continue
        kept = dict(nodes)
        try:
            outputs.append((target, node(src[0]), src[1], src[2]))
        except _Bad as exc:
            nodes.clear()
            nodes.update(kept)
            warnings.append(f"{exc}; {target} uses the UsdPreviewSurface value")
    if not outputs:
        return None
    # Names relative to the material, so that equal graphs in two materials match.
    prefix = len(path) + 1
    rel = {n: n[prefix:] for n in nodes}
    order = [nodes[n] for n in nodes if nodes[n] is not None]
    order = _sources_first(order)
    renamed = tuple(PatternNode(name=rel[n.name], kind=n.kind, settings=n.settings,
                                values=n.values,
                                links=tuple((i, t, rel[s], o, st) for i, t, s, o, st in n.links))
                    for n in order)
    return PatternGraph(nodes=renamed,
                        outputs=tuple((t, rel[n], o, ot) for t, n, o, ot in outputs))


def _sources_first(nodes):
    """Nodes ordered so that every link's source comes before its user (stable)."""
    by_name = {n.name: n for n in nodes}
    done, order = set(), []

    def visit(n):
        if n.name in done:
            return
        done.add(n.name)
        for link in n.links:
            visit(by_name[link[2]])
        order.append(n)

    for n in nodes:
        visit(n)
    return order
