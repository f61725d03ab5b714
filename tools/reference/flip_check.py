#!/usr/bin/env python3
"""HDR-FLIP by NVIDIA's own implementation on pairs of the stored references.

    python3 tools/reference/flip_check.py > crates/nimbus-cli/tests/data/flip_nvidia.json

`nimbus compare` computes HDR-FLIP over the `nv-flip` crate, whose LDR-FLIP
takes 8-bit sRGB. This script evaluates the same pairs with NVIDIA's
`flip-evaluator` (the authors' Python package, version pinned in
requirements.txt) twice: its HDR-FLIP on float images (the published
metric), and the same exposures, tone curve and per-pixel maximum with each
exposure quantised to 8-bit sRGB before NVIDIA's LDR-FLIP (what nimbus
computes). The test `hdr_flip_matches_nvidias_implementation` reads the
result: nimbus must reproduce the second, and stay within the quantisation's
measured effect of the first.

Pairs (all 320x180 half-float EXRs in crates/nimbus-cli/tests/data/flip/: the
realism references of 64 samples per pixel that this check was made on, kept
here when the suite's references were re-rendered):
a reference against itself with its channels scaled by (1.1, 1.0, 0.9)
(a small error), and two references of different scenes (large errors).
"""
import json
import os
import sys

import numpy as np

os.environ.setdefault("DRJIT_LIBLLVM_PATH", "/usr/lib/x86_64-linux-gnu/libLLVM.so.19.1")
import mitsuba as mi  # noqa: E402  (EXR reading)
import flip_evaluator as flip  # noqa: E402

mi.set_variant("scalar_rgb")
REFERENCES = "crates/nimbus-cli/tests/data/flip"
# (reference, test, per-channel scale of the test)
PAIRS = [
    ("cumulus-front-lit", "cumulus-front-lit", [1.1, 1.0, 0.9]),
    ("stratus-side", "stratus-overcast-below", [1.0, 1.0, 1.0]),
    ("rain-drizzle", "rain-heavy", [1.0, 1.0, 1.0]),
]
# Plus a noise-like difference: the reference scaled by 1.05 and 0.95 on a
# checkerboard (pixel (x, y) gets 1.05 where x + y is even).
CHECKER = ("cumulus-back-lit", [0.05])
# FLIP's ACES fit with its 0.6 input scale (Narkowicz 2015; flip.h).
PIXELS_PER_DEGREE = 67.02064514160156  # FLIP's default viewing condition
ACES = [0.6 * 0.6 * 2.51, 0.6 * 0.03, 0.0, 0.6 * 0.6 * 2.43, 0.6 * 0.59, 0.14]


def load(name):
    root = dict(mi.Bitmap(f"{REFERENCES}/{name}.exr").split())["<root>"]
    names = [f.name for f in root.struct_()]
    a = np.array(root, dtype=np.float32)
    return np.ascontiguousarray(np.stack([a[..., names.index(c)] for c in "RGB"], -1))


def tone_map(x):
    a, b, c, d, e, f = ACES
    return np.clip((a * x * x + b * x + c) / (d * x * x + e * x + f), 0.0, 1.0)


def srgb8(linear):
    encoded = np.where(linear <= 0.0031308, 12.92 * linear, 1.055 * np.power(linear, 1 / 2.4) - 0.055)
    return (np.clip(np.round(encoded * 255.0), 0, 255) / 255.0).astype(np.float32)


def main():
    results = []
    for reference_name, test_name, scale in PAIRS:
        reference = load(reference_name)
        test = load(test_name) * np.array(scale, dtype=np.float32)
        results.append(entry(reference, test, reference_name, test_name, scale))
    reference = load(CHECKER[0])
    y, x = np.mgrid[0:reference.shape[0], 0:reference.shape[1]]
    factor = np.where((x + y) % 2 == 0, np.float32(1.0 + CHECKER[1][0]), np.float32(1.0 - CHECKER[1][0]))
    test = reference * factor[..., None].astype(np.float32)
    results.append(entry(reference, test, CHECKER[0], "checkerboard", CHECKER[1]))
    json.dump({"flip_evaluator": "1.7", "pixels_per_degree": PIXELS_PER_DEGREE, "pairs": results},
              sys.stdout, indent=2)
    print()


def entry(reference, test, reference_name, test_name, scale):
    """NVIDIA's HDR-FLIP mean, and the same with 8-bit exposures."""
    _, mean, params = flip.evaluate(reference, test, "HDR", applyMagma=False)
    exposures = np.linspace(params["startExposure"], params["stopExposure"], params["numExposures"])
    error = np.zeros(reference.shape[:2], dtype=np.float32)
    for stops in exposures:
        r = srgb8(tone_map(reference * np.float32(2.0**stops)))
        t = srgb8(tone_map(test * np.float32(2.0**stops)))
        m, _, _ = flip.evaluate(r, t, "LDR", inputsRGB=True, applyMagma=False)
        error = np.maximum(error, m.reshape(error.shape))
    return {
        "reference": reference_name,
        "test": test_name,
        "test_scale": scale,
        "hdr_flip_mean": float(mean),
        "hdr_flip_mean_8bit_exposures": float(error.mean()),
        "start_exposure": float(params["startExposure"]),
        "stop_exposure": float(params["stopExposure"]),
        "exposures": int(params["numExposures"]),
    }


if __name__ == "__main__":
    main()
