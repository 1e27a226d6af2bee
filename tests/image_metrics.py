"""Image error against a reference: PSNR and mean FLIP on scene-linear images."""
import numpy as np


def psnr(image, reference):
    """PSNR in dB of display-clamped linear RGB, peak 1."""
    a = np.clip(image[..., :3], 0.0, 1.0)
    b = np.clip(reference[..., :3], 0.0, 1.0)
    mse = float(np.mean((a - b) ** 2))
    return float("inf") if mse == 0.0 else 10.0 * np.log10(1.0 / mse)


def mean_flip(image, reference):
    """Mean HDR-FLIP (flip-evaluator) of linear RGB."""
    import flip_evaluator as flip
    ref = np.ascontiguousarray(reference[..., :3], dtype=np.float32)
    test = np.ascontiguousarray(image[..., :3], dtype=np.float32)
    _, mean, _ = flip.evaluate(ref, test, "HDR")
    return float(mean)

