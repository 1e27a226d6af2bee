"""The reading of materials (bound per mesh and per GeomSubset, shared by name) and
lights (UsdLux, the one dome, usdview's default rig when the stage has none) into scene
records."""
from __future__ import annotations

import numpy as np
from pxr import UsdGeom, UsdShade

from ..lighting import default_dome, headlight
from ..scene import Changes
from .lights import Dome, light_values, light_varies, read_light
from .materials import default_material, read_material
from .materials import might_vary as material_might_vary
from .paths import traversal_order
from .validate import check_binding

HEADLIGHT = "<headlight>"


class ShadingReading:
    """StageReader's reading of materials and lights (state: stage.py)."""

    def _face_materials(self, prim, warnings):
        """[Material] (the prim's, then one per bound GeomSubset) and [(Material name,
        face indices)] per subset. A binding to a prim that is not a Material is a
        warning, and the mesh gets the default material."""
        binding = UsdShade.MaterialBindingAPI(prim)
        base = binding.ComputeBoundMaterial()[0]
        if base:
            base_mat = self._material(base)
        else:
            check_binding(prim, warnings)
            gprim = UsdGeom.Gprim(prim)
            dc = gprim.GetDisplayColorAttr().Get()
            do = gprim.GetDisplayOpacityAttr().Get()
            base_mat = default_material(dc[0] if dc else None, do[0] if do else None)
            self.scene.materials.setdefault(base_mat.name, base_mat)
        mats, subsets = [base_mat], []
        for subset in binding.GetMaterialBindSubsets():
            m = UsdShade.MaterialBindingAPI(subset.GetPrim()).ComputeBoundMaterial()[0]
            if not m:
                check_binding(subset.GetPrim(), warnings)
            if m:
                idx = subset.GetIndicesAttr().Get()
                mat = self._material(m)
                mats.append(mat)
                subsets.append((mat.name, np.array(idx if idx is not None else [], np.int64)))
        return mats, subsets

    def _material(self, mat: UsdShade.Material, force: bool = False):
        prim = mat.GetPrim()
        if prim.IsInstanceProxy():
            # Every instance of an instanceable reference binds the same material:
            # one record, named by the prototype's prim, so their meshes share data.
            prim = prim.GetPrimInPrototype()
            mat = UsdShade.Material(prim)
        name = str(prim.GetPath())
        if force or name not in self.scene.materials:
            warnings = self.scene.warnings[name] = []
            self._forget_tiles(name)
            material = self.scene.materials[name] = read_material(mat, self._t, warnings)
            for tile in material.udim_tiles[1:]:     # the first tile draws with `material`
                self.scene.materials[material.tile_name(tile)] = material.for_tile(tile)
            self._material_varies[name] = material_might_vary(mat)
            self._read.add(name)
        return self.scene.materials[name]

    def _forget_tiles(self, name):
        old = self.scene.materials.get(name)
        for tile in old.udim_tiles[1:] if old is not None else ():
            self.scene.materials.pop(old.tile_name(tile), None)

    def _unuse_material(self, name, path):
        users = self._material_users.get(name)
        if users is not None:
            users.discard(path)
            if not users:
                del self._material_users[name]
                self._forget_material(name)

    def _forget_material(self, name):
        self._forget_tiles(name)
        self.scene.materials.pop(name, None)
        self._material_varies.pop(name, None)
        self.scene.warnings.pop(name, None)

    def _reread_material(self, name: str, changes: Changes):
        """A material edit: the record is replaced; meshes whose layout depends on it
        (its UV set, whether it needs tangents) are rebuilt."""
        prim = self.stage.GetPrimAtPath(name)
        old = self.scene.materials.get(name)
        users = set(self._material_users.get(name, ()))
        if not prim or not prim.IsA(UsdShade.Material):
            self._forget_material(name)
            relayout = users
        else:
            new = self._material(UsdShade.Material(prim), force=True)
            changes.materials.add(name)
            changes.materials.update(new.tile_name(t) for t in new.udim_tiles[1:])
            relayout = users if old is None or old.mesh_layout != new.mesh_layout else set()
        for path in relayout:
            p = self.stage.GetPrimAtPath(path)
            if p:
                self._read_instance(p, changes, rebuild=True)

    def _read_light(self, prim, changes: Changes, path: str | None = None):
        """(Re)reads a UsdLux prim (`path`: its path, where the caller has it). Whether
        it may vary in time is asked at the next new time (_light_varies), not here:
        an image at one time never needs it, and it was a quarter of a light's read."""
        path = path or str(prim.GetPath())
        self._read.add(path)
        warnings = self.scene.warnings[path] = []
        values, ops = light_values(prim, self._t)
        self._light_prims[path] = None
        rec = read_light(prim, path, self._world(path, prim, ops), values, warnings)
        if isinstance(rec, Dome):
            self._domes[path] = rec
            changes.dome = True
        elif rec is not None:
            self._lights_moved |= path not in self.scene.lights
            self.scene.lights[path] = rec
            changes.lights.add(path)
        else:
            self._drop_light(path, changes, keep_prim=True)

    def _light_varies(self, path) -> bool:
        """Whether the light must be read again at a new time: an input or xform op of
        its own may vary, or an ancestor's transform may."""
        prim = self.stage.GetPrimAtPath(path)
        if not prim:
            return False
        parent = prim.GetParent()
        return light_varies(prim) or (not parent.IsPseudoRoot() and self._xform_varies(parent))

    def _drop_light(self, path, changes: Changes, keep_prim: bool = False):
        if not keep_prim:
            self._light_prims.pop(path, None)
        if self.scene.lights.pop(path, None) is not None:
            changes.lights.add(path)
            self._lights_moved = True
        if self._domes.pop(path, None) is not None:
            changes.dome = True

    def _finish_lights(self, changes: Changes):
        """The one dome (the first in traversal order), and usdview's default rig when
        the stage has no UsdLux prim at all. Lights keep the stage's traversal order
        (they add up in a float16 target, where the order shows in the last bit)."""
        if self._lights_moved and len(self.scene.lights) > 1:
            order = traversal_order(self.stage, set(self.scene.lights) - {HEADLIGHT})
            self.scene.lights = dict(sorted(self.scene.lights.items(),
                                            key=lambda kv: order.get(kv[0], -1)))
        self._lights_moved = False
        if changes.dome:
            domes = self._domes
            if len(domes) > 1:
                order = traversal_order(self.stage, set(domes))
                domes = dict(sorted(domes.items(), key=lambda kv: order.get(kv[0], 0)))
            first = next(iter(domes), None)
            for path in domes:
                ws = self.scene.warnings.setdefault(path, [])
                skip = f"{path}: only one dome light is used; skipped"
                if path != first and skip not in ws:
                    ws.append(skip)
                elif path == first and skip in ws:
                    ws.remove(skip)
            self.scene.dome = domes[first] if first is not None else None
        rig = not self._light_prims and not self.emitters.lights_of   # emitters light it
        if rig and HEADLIGHT not in self.scene.lights:
            self.scene.lights[HEADLIGHT] = headlight()
            self.scene.dome = default_dome()
            changes.lights.add(HEADLIGHT)
            changes.dome = True
        elif not rig and HEADLIGHT in self.scene.lights:
            del self.scene.lights[HEADLIGHT]
            changes.lights.add(HEADLIGHT)
            if not self._domes:
                self.scene.dome = None
                changes.dome = True
