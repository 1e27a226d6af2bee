"""Light numbers that need neither USD nor GL: light volumes, the environment's
spherical harmonics, area-light polygons, and usdview's default rig.

Light volumes: a light's volume reaches the distance R where the largest radiance it
can reflect off a white Lambert surface, I_max / (pi R^2), falls below
VOLUME_THRESHOLD = 1e-4 W/(sr m2) (I_max = max channel of I; for area lights I_max =
L * area, the far-field intensity along the normal). Glossy highlights beyond R are
cut off.

No UsdLux prim on the stage at all: a usdview-style default rig, a headlight (a
distant light travelling along the camera's view direction, E = 2.5 W/m2) plus a
uniform grey dome of radiance 0.2 W/(sr m2): a white Lambert surface facing the camera
reads 2.5/pi + 0.2 ~ 1.0.

Dome: order-2 spherical harmonics irradiance, computed here with numpy; lat-long
mapping as Hydra Storm's: in the dome's frame +Y is up (image top), u = (atan2(z, x) +
pi/2) / 2pi."""
from __future__ import annotations

import math

import numpy as np

from ..core.lights import DISK, RECT, SUN
from .scene import Dome, Light

VOLUME_THRESHOLD = 1e-4
HEADLIGHT_IRRADIANCE = 2.5
DEFAULT_DOME_RADIANCE = 0.2


def volume_radius(light: Light) -> float:
    """Distance beyond which the light reflects < VOLUME_THRESHOLD off white Lambert."""
    c = float(np.max(light.color)) * max(light.diffuse, light.specular, 0.0)
    if light.kind in (RECT, DISK):
        area = light.width * light.height if light.kind == RECT else math.pi * light.radius ** 2
        c *= area
        extent = math.hypot(light.width, light.height) / 2 if light.kind == RECT else light.radius
    else:
        extent = light.radius
    if c <= 0:
        return 0.0
    return math.sqrt(c / (math.pi * VOLUME_THRESHOLD)) + extent


def disk_polygon(light: Light, sides: int) -> np.ndarray:
    """Equal-area regular polygon for a disk light."""
    R = light.radius * math.sqrt(2 * math.pi / (sides * math.sin(2 * math.pi / sides)))
    ang = np.arange(sides) * 2 * math.pi / sides
    return light.position + (np.outer(np.cos(ang), light.x_axis) + np.outer(np.sin(ang), light.y_axis)) * R


def rect_polygon(light: Light) -> np.ndarray:
    hx, hy = light.x_axis * light.width / 2, light.y_axis * light.height / 2
    c = light.position
    return np.array([c - hx - hy, c + hx - hy, c + hx + hy, c - hx + hy])


def headlight() -> Light:
    """usdview's headlight: a sun along the view, wherever the camera looks."""
    return Light(kind=SUN, name="<headlight>", color=np.full(3, HEADLIGHT_IRRADIANCE),
                 shadow=False, headlight=True)


def default_dome() -> Dome:
    rad = np.full(3, DEFAULT_DOME_RADIANCE)
    return Dome(name="<default dome>", radiance=rad, sh=uniform_sh(rad))


# --- order-2 spherical harmonics -------------------------------------------------
# Irradiance E(n) = sum_lm A_l L_lm Y_lm(n) (Ramamoorthi & Hanrahan 2001). The
# coefficients handed to the shader already include A_l, so the shader only
# evaluates the basis; sh_basis here and sh_irradiance in lib.glsl must agree.
_A = np.array([math.pi] + [2 * math.pi / 3] * 3 + [math.pi / 4] * 5)


def sh_basis(d: np.ndarray) -> np.ndarray:
    x, y, z = d[..., 0], d[..., 1], d[..., 2]
    return np.stack([
        np.full_like(x, 0.282095),
        0.488603 * y, 0.488603 * z, 0.488603 * x,
        1.092548 * x * y, 1.092548 * y * z, 0.315392 * (3 * z * z - 1),
        1.092548 * x * z, 0.546274 * (x * x - y * y)], axis=-1)


def uniform_sh(radiance) -> np.ndarray:
    sh = np.zeros((9, 3))
    sh[0] = np.asarray(radiance, float) * 4 * math.pi * 0.282095 * _A[0]
    return sh


def load_latlong(path: str) -> np.ndarray:
    from .textures import read_image_linear
    img = read_image_linear(path, "auto")[..., :3]
    # A few thousand samples are plenty for order-2 harmonics.
    step = max(1, img.shape[1] // 256)
    return img[::step, ::step].astype(np.float64)


def latlong_dirs(h: int, w: int) -> tuple[np.ndarray, np.ndarray]:
    """Dome-frame directions of pixel centres (row 0 = top = +Y) and solid angles."""
    theta = (np.arange(h) + 0.5) / h * math.pi
    phi = (np.arange(w) + 0.5) / w * 2 * math.pi - math.pi / 2
    th, ph = np.meshgrid(theta, phi, indexing="ij")
    d = np.stack([np.sin(th) * np.cos(ph), np.cos(th), np.sin(th) * np.sin(ph)], axis=-1)
    dw = (2 * math.pi / w) * (math.pi / h) * np.sin(th)
    return d, dw


def latlong_sh(img: np.ndarray, rotation: np.ndarray) -> np.ndarray:
    h, w = img.shape[:2]
    d, dw = latlong_dirs(h, w)
    d = d @ rotation.T
    Y = sh_basis(d)                                   # (h, w, 9)
    L = np.einsum("hwk,hwc,hw->kc", Y, img, dw)       # projection of radiance
    return L * _A[:, None]
