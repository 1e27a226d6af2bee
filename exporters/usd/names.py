"""Valid, unique prim names."""
from pxr import Sdf, Tf


class Namer:
    """Hands out sanitised child names, unique under each parent path."""

    def __init__(self):
        self._used = {}

    def reserve(self, parent, name):
        self._used.setdefault(str(parent), set()).add(name)

    def child(self, parent, name):
        used = self._used.setdefault(str(parent), set())
        base = Tf.MakeValidIdentifier(name or "unnamed")
        candidate, n = base, 1
        while candidate in used:
            candidate = f"{base}_{n}"
            n += 1
        used.add(candidate)
        return Sdf.Path(str(parent)).AppendChild(candidate)


def primvar_name(uv_name):
    return Tf.MakeValidIdentifier(uv_name)


def set_blender_name(prim, name):
    prim.CreateAttribute("lantern:blenderName", Sdf.ValueTypeNames.String,
                         custom=True).Set(name)


def set_pass_index(prim, index):
    """Blender's pass index (render passes IndexOB, IndexMA), authored only when set."""
    if index:
        prim.CreateAttribute("lantern:passIndex", Sdf.ValueTypeNames.Int,
                             custom=True).Set(int(index))
