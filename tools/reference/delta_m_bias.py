#!/usr/bin/env python3
"""The δ-M truncation's bias (docs/REALISM.md): a scene rendered with the
droplets' forward peak truncated and with the full phase function, each as
two halves, compared over nimbus's cloud pixels.

    python3 tools/reference/delta_m_bias.py TRUNCATED_DIR FULL_DIR REALTIME.exr

TRUNCATED_DIR and FULL_DIR each hold reference_a.exr and reference_b.exr
(render.py --halves) and reference.json; REALTIME.exr is `nimbus render`'s
EXR of the same scene, whose cloud.A layer (>= 0.05) gives the pixels.
Prints the mean luminance and red/blue over those pixels for each render,
with standard errors from its halves (the variance of a mean is the sum of
the half-differences' squares over n², per channel with covariances), and
the truncated/full ratios with their combined standard errors.
"""
import json
import os
import sys

import numpy as np

os.environ.setdefault("DRJIT_LIBLLVM_PATH", "/usr/lib/x86_64-linux-gnu/libLLVM.so.19.1")
import mitsuba as mi  # noqa: E402  (EXR reading)

mi.set_variant("scalar_rgb")
Y = np.array([0.2126, 0.7152, 0.0722])


def layers(path):
    return {name: np.array(b, copy=False) for name, b in mi.Bitmap(path).split()}


def stats(folder, mask):
    a = np.array(mi.Bitmap(f"{folder}/reference_a.exr"))[..., :3][mask].astype(np.float64)
    b = np.array(mi.Bitmap(f"{folder}/reference_b.exr"))[..., :3][mask].astype(np.float64)
    s, h = 0.5 * (a + b), 0.5 * (a - b)
    n = len(s)
    mean = s.mean(axis=0)
    cov = h.T @ h / n**2
    lum = mean @ Y
    lum_se = np.sqrt(Y @ cov @ Y)
    rb = mean[0] / mean[2]
    rb_se = np.sqrt(max(cov[0, 0] - 2 * rb * cov[0, 2] + rb * rb * cov[2, 2], 0.0)) / mean[2]
    info = json.load(open(f"{folder}/reference.json"))
    return lum, lum_se, rb, rb_se, info


def main():
    truncated, full, realtime = sys.argv[1:4]
    root = layers(realtime)
    if "cloud" not in root:
        sys.exit(f"{realtime}: no cloud.A layer")
    height, width = root["<root>"].shape[:2]
    mask = root["cloud"].reshape(height, width, -1)[..., 0] >= 0.05
    t = stats(truncated, mask)
    f = stats(full, mask)
    for label, (lum, lum_se, rb, rb_se, info) in (("truncated", t), ("full", f)):
        print(f"{label}: {info['spp']} spp, {info['total_seconds']:.0f} s: mean luminance "
              f"{lum:.4f} ± {lum_se:.4f} ({lum_se / lum:.2%}), red/blue {rb:.4f} ± {rb_se:.4f}")
    ratio = t[0] / f[0]
    ratio_se = ratio * np.hypot(t[1] / t[0], f[1] / f[0])
    rb_ratio = t[2] / f[2]
    rb_ratio_se = rb_ratio * np.hypot(t[3] / t[2], f[3] / f[2])
    print(f"truncated / full: luminance {ratio:.4f} ± {ratio_se:.4f} ({(ratio - 1) / ratio_se:+.1f} σ), "
          f"red/blue {rb_ratio:.4f} ± {rb_ratio_se:.4f} ({(rb_ratio - 1) / rb_ratio_se:+.1f} σ); "
          f"pixels {int(mask.sum())}")


if __name__ == "__main__":
    main()
