"""Bounces: how often light bounces, a plain record that the stage (/Render/Settings)
and a render's settings both carry."""
from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class Bounces:
    """How often light may bounce on its way to the camera, as Cycles counts it (Render
    Properties > Light Paths): `total` is Max Bounces, `diffuse` and `glossy` cap each
    kind. Cycles' defaults; total 0 is direct light only."""
    total: int = 12
    diffuse: int = 4
    glossy: int = 4

    def __post_init__(self):
        for name in ("total", "diffuse", "glossy"):
            v = getattr(self, name)
            if isinstance(v, bool) or int(v) != v or v < 0:
                raise ValueError(f"bounces: {name} must be a whole number >= 0, not {v!r}")

    @property
    def diffuse_bounces(self) -> int:
        """Diffuse bounces a path may take: the smaller cap."""
        return min(self.total, self.diffuse)

    @property
    def glossy_bounces(self) -> int:
        return min(self.total, self.glossy)


DIRECT = Bounces(0, 0, 0)
