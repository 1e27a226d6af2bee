"""Image error against a reference: PSNR and mean FLIP on scene-linear images; Cycles'
pixel filter in numpy, the reference the GPU's supersampling is held to."""
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



def downsample(image, k):
    """Cycles' pixel filter (passes/antialias.py downsample_taps) applied separably to
    an image k times larger than the result, row 0 = top, in float64."""
    from lantern.engine.gpu.passes.antialias import downsample_taps
    if k == 1:
        return image
    offsets, weights = downsample_taps(k)
    out = image.astype(np.float64)
    for axis in (0, 1):
        n = out.shape[axis] // k
        idx = np.clip(np.arange(n)[:, None] * k + offsets[None, :], 0, out.shape[axis] - 1)
        out = np.tensordot(np.take(out, idx, axis=axis), weights, axes=([axis + 1], [0]))
    return out.astype(np.float32)
