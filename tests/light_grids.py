"""Stages with thousands of sphere lights, authored as Sdf specs in one change block:
20,000 UsdLux.SphereLight.Define calls would cost more than rendering them. Used by
tests/test_many_lights.py and bench/bench_light_scaling.py."""
from pxr import Gf, Sdf


def add_sphere_lights(stage, parent, positions, inputs, shadows, treat_as_point=False):
    """A SphereLight under `parent` (a prim path) at each position, with the `inputs`
    given (floats or bools: {"intensity": 50.0, "normalize": True}), shadows on or off."""
    root, types = stage.GetRootLayer().GetPrimAtPath(parent), Sdf.ValueTypeNames
    width = len(str(max(len(positions) - 1, 0)))
    with Sdf.ChangeBlock():
        for i, position in enumerate(positions):
            spec = Sdf.PrimSpec(root, f"light_{i:0{width}d}", Sdf.SpecifierDef, "SphereLight")
            spec.SetInfo("apiSchemas", Sdf.TokenListOp.Create(prependedItems=["ShadowAPI"]))
            values = [(f"inputs:{name}", types.Bool if isinstance(value, bool) else types.Float,
                       value) for name, value in inputs.items()]
            values += [("inputs:shadow:enable", types.Bool, shadows),
                       ("xformOp:translate", types.Double3, Gf.Vec3d(*position))]
            if treat_as_point:
                values.append(("treatAsPoint", types.Bool, True))
            for name, kind, value in values:
                Sdf.AttributeSpec(spec, name, kind).default = value
            Sdf.AttributeSpec(spec, "xformOpOrder", types.TokenArray,
                              variability=Sdf.VariabilityUniform).default = ["xformOp:translate"]
