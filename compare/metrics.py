"""Image error against a reference, in scene-linear RGB (alpha is not scored).

- HDR-FLIP: flip-evaluator on the linear images as they are (its exposure range comes
  from the reference, so every image is judged at the same exposures);
- LDR-FLIP: flip-evaluator on the linear images clamped to [0, 1] (inputsRGB=False:
  they are linear, not sRGB-encoded);
- PSNR (dB, peak 1) and SSIM (scikit-image, data range 1, 7-pixel window) on the
  linear images clamped to [0, 1];
- relative MSE: mean of (x - r)² / (r² + 0.01) over pixels and channels, unclamped.
Each also over the foreground only (a boolean mask): FLIP and SSIM average their
per-pixel maps there, PSNR and relative MSE take their means there.

Nothing is repaired before scoring: an image with non-finite pixels gets no metrics
and says how many it has; negative values (which no renderer should produce) are
counted, and clamped to 0 for FLIP only, which cannot read them."""
from __future__ import annotations

import math

import numpy as np

REL_MSE_EPSILON = 0.01
FLIP_KINDS = ("hdr_flip", "ldr_flip")
METRICS = ("hdr_flip", "ldr_flip", "psnr", "ssim", "rel_mse")


def problems(rgba: np.ndarray) -> dict:
    rgb = np.asarray(rgba)[..., :3]
    finite = np.isfinite(rgb)
    return {"nonfinite_pixels": int((~finite).any(axis=-1).sum()),
            "negative_pixels": int((np.where(finite, rgb, 0.0) < 0).any(axis=-1).sum())}


def _flip_map(reference, test, kind):
    import flip_evaluator as flip
    if kind == "hdr_flip":
        ref, img, mode, extra = np.maximum(reference, 0), np.maximum(test, 0), "HDR", {}
    else:
        ref, img, mode, extra = np.clip(reference, 0, 1), np.clip(test, 0, 1), "LDR", \
            {"inputsRGB": False}
    error_map, _, parameters = flip.evaluate(
        np.ascontiguousarray(ref, dtype=np.float32), np.ascontiguousarray(img, dtype=np.float32),
        mode, applyMagma=False, **extra)
    return np.asarray(error_map, dtype=np.float64).reshape(reference.shape[:2]), parameters


def _ssim_map(reference, test):
    from skimage.metrics import structural_similarity
    _, full = structural_similarity(np.clip(reference, 0, 1), np.clip(test, 0, 1),
                                    channel_axis=-1, data_range=1.0, full=True)
    return full.mean(axis=-1)


def _psnr(squared_error):
    mse = float(squared_error.mean()) if squared_error.size else float("nan")
    if mse == 0.0:
        return None  # identical: infinite PSNR, which JSON cannot hold
    return 10.0 * math.log10(1.0 / mse) if math.isfinite(mse) else None


def _mean(values):
    return float(values.mean()) if values.size else None


def score(test: np.ndarray, reference: np.ndarray, mask: np.ndarray | None = None) -> dict:
    """{"all": {metric: value}, "foreground": {...} or None, "flip_maps": {...},
    "problems": {...}} for RGB(A) float images of one size."""
    test = np.asarray(test, dtype=np.float64)[..., :3]
    reference = np.asarray(reference, dtype=np.float64)[..., :3]
    if test.shape != reference.shape:
        raise ValueError(f"image is {test.shape[1]}x{test.shape[0]}, the reference "
                         f"{reference.shape[1]}x{reference.shape[0]}")
    found = problems(test)
    if found["nonfinite_pixels"] or not np.isfinite(reference).all():
        return {"all": None, "foreground": None, "flip_maps": {}, "problems": found}
    maps = {}
    for kind in FLIP_KINDS:
        maps[kind], _ = _flip_map(reference, test, kind)
    ssim = _ssim_map(reference, test)
    clamped_se = ((np.clip(test, 0, 1) - np.clip(reference, 0, 1)) ** 2).mean(axis=-1)
    rel = ((test - reference) ** 2 / (reference ** 2 + REL_MSE_EPSILON)).mean(axis=-1)

    def summary(select):
        return {"hdr_flip": _mean(maps["hdr_flip"][select]),
                "ldr_flip": _mean(maps["ldr_flip"][select]),
                "psnr": _psnr(clamped_se[select]),
                "ssim": _mean(ssim[select]),
                "rel_mse": _mean(rel[select])}

    everything = np.ones(reference.shape[:2], dtype=bool)
    foreground = None
    if mask is not None and mask.any():
        foreground = summary(mask)
    return {"all": summary(everything), "foreground": foreground, "flip_maps": maps,
            "problems": found}


def flip_parameters(reference: np.ndarray) -> dict:
    """The HDR-FLIP parameters (pixels per degree, exposure range) a reference sets."""
    ref = np.asarray(reference, dtype=np.float64)[..., :3]
    _, parameters = _flip_map(ref, ref, "hdr_flip")
    return {k: (float(v) if isinstance(v, (int, float)) and math.isfinite(v) else str(v))
            for k, v in parameters.items()}
