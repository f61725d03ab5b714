#!/usr/bin/env python3
"""Least-squares fit of the cumulus shader's four weights to the realism
suite's path-traced references (docs/REALISM.md, "Fitted cumulus weights").

    python3 tools/reference/fit_cumulus.py [--nimbus target/debug/nimbus]
        [--fit NAME ...] [--held-out NAME ...] [--json OUT]

The phenomenological shader's radiance (Bouthors 2004, eq 5.42) is linear in
its weights: I = α_a C_c + E C_s (α_l L + α_f F + α_t T). Everything after
the shader is affine in I for fixed opacities (the opaque bodies, the
weighted-blended fringes, the aerial perspective), and the opacities do not
depend on the weights. So each pixel of the image is

    P = P_0 + Σ_k α_k B_k,

P_0 the image with every weight at 0 (sky, terrain; rendered without
aerial perspective, as the references are) and B_k the image with α_k = 1 and the others 0, minus P_0. The tool
renders those five images of each scene with `nimbus render`, checks the
linearity against the scene's own render, and solves for the weights that
minimise, over the cloud pixels (cloud.A > 0.05, as `nimbus compare --mask
cloud`) of the fit scenes and the three colour channels,

    Σ_scenes 1/N_s Σ_pixels ((P − R) / mean(R_s))²,

R the reference: relative errors, each scene weighing the same whatever its
brightness or pixel count. The weights are kept non-negative (the active
sets of the four are enumerated). The references' fireflies are zero-mean,
so they widen the fit's scatter but do not bias it; pixels are averaged
over 2×2 blocks first to tame them.

Needs numpy, OpenEXR and tomli-w (requirements.txt); nimbus built.
"""
import argparse
import itertools
import json
import os
import subprocess
import sys
import tomllib

import numpy as np
import OpenEXR
import tomli_w

WEIGHTS = ["ambient", "lambert", "light_traps", "transmission", "diffusion", "forward_peak"]
MASK_THRESHOLD = 0.05
# Reuse the renders of an earlier run (--reuse).
REUSE = False
# Side of the pixel blocks averaged before the fit (--block).
BLOCK = 2
ROOT = os.path.normpath(os.path.join(os.path.dirname(__file__), "..", ".."))


def read_layers(path):
    """RGB (H×W×3) and cloud.A (H×W, or None) of an EXR."""
    channels = OpenEXR.File(path).parts[0].channels
    rgb = np.asarray(channels["RGB"].pixels, dtype=np.float64)
    alpha = channels.get("cloud.A")
    return rgb, None if alpha is None else np.asarray(alpha.pixels, dtype=np.float64)


def render(nimbus, scene, weights, out_dir, tag):
    """Renders `scene` with the shader's weights replaced; returns its layers."""
    with open(scene, "rb") as f:
        settings = tomllib.load(f)
    # The references have no air between the camera and the clouds (the
    # sky is an environment map at infinity): nor has the fit's image.
    settings.setdefault("camera", {})["aerial_perspective"] = False
    shading = settings.setdefault("cumulus", {}).setdefault("shading", {})
    shading.pop("model", None)
    shading.update(weights)
    variant = os.path.join(out_dir, f"{tag}.toml")
    with open(variant, "wb") as f:
        tomli_w.dump(settings, f)
    exr = os.path.join(out_dir, f"{tag}.exr")
    if REUSE and os.path.exists(exr):
        return read_layers(exr)
    subprocess.run([nimbus, "render", variant, "-o", exr], check=True,
                   stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    return read_layers(exr)


def blocks(a, n=None):
    """Mean over n×n blocks (the trailing rows and columns dropped)."""
    n = n or BLOCK
    h, w = a.shape[0] // n * n, a.shape[1] // n * n
    a = a[:h, :w]
    return a.reshape(h // n, n, w // n, n, *a.shape[2:]).mean(axis=(1, 3))


def read_reference(name):
    """The stored reference's RGB: the mean of its two independent halves
    (tools/reference/suite.sh keeps NAME_a.exr and NAME_b.exr)."""
    stem = os.path.join(ROOT, "scenes", "realism", "references", name)
    halves = [read_layers(f"{stem}_{h}.exr")[0] for h in "ab"]
    return 0.5 * (halves[0] + halves[1])


def scene_system(nimbus, name, out_dir):
    """The scene's design matrix, target and metadata over its cloud pixels."""
    scene = os.path.join(ROOT, "scenes", "realism", f"{name}.toml")
    reference = read_reference(name)
    zero = {w: 0.0 for w in WEIGHTS}
    base, alpha = render(nimbus, scene, zero, out_dir, f"{name}-zero")
    basis = []
    for w in WEIGHTS:
        image, _ = render(nimbus, scene, {**zero, w: 1.0}, out_dir, f"{name}-{w}")
        basis.append(image - base)
    # Linearity: arbitrary weights through the basis against their render.
    probe = dict(zip(WEIGHTS, [0.5, 0.25, 0.4, 1.5, 0.3, 0.7]))
    full, _ = render(nimbus, scene, probe, out_dir, f"{name}-probe")
    predicted = base + sum(probe[w] * b for w, b in zip(WEIGHTS, basis))
    mask = alpha > MASK_THRESHOLD
    linearity = float(np.abs(predicted - full)[mask].max() / max(full[mask].mean(), 1e-30))

    block_mask = blocks(mask.astype(np.float64)) > 0.999
    scale = reference[mask].mean()
    rows = np.stack([blocks(b)[block_mask].ravel() for b in basis], axis=1) / scale
    target = (blocks(reference) - blocks(base))[block_mask].ravel() / scale
    return {
        "name": name,
        "matrix": rows,
        "target": target,
        "weight": 1.0 / len(target),
        "linearity": linearity,
        "pixels": int(mask.sum()),
    }


# The paper's weights (Bouthors 2004, appendix B; nimbus_physics::cumulus::
# shading::CumulusShading::bouthors2004), the fit's starting point.
PAPER = {"ambient": 0.75, "lambert": 0.35, "light_traps": 0.3, "transmission": 2.0,
         "diffusion": 0.0, "forward_peak": 0.0}


def solve(systems, fixed=()):
    """Non-negative weighted least squares over the systems (active sets
    enumerated); the weights named in `fixed` stay at 0."""
    a = np.concatenate([s["matrix"] * np.sqrt(s["weight"]) for s in systems])
    b = np.concatenate([s["target"] * np.sqrt(s["weight"]) for s in systems])
    best = None
    for free in itertools.product([False, True], repeat=len(WEIGHTS)):
        idx = [i for i, f in enumerate(free) if f and WEIGHTS[i] not in fixed]
        x = np.zeros(len(WEIGHTS))
        if idx:
            x[idx] = np.linalg.lstsq(a[:, idx], b, rcond=None)[0]
        if (x < 0).any():
            continue
        cost = float(np.sum((a @ x - b) ** 2))
        if best is None or cost < best[1]:
            best = (x, cost)
    return best[0]


def relative_rms(system, x):
    r = system["matrix"] @ x - system["target"]
    return float(np.sqrt(np.mean(r ** 2)))


def main():
    global REUSE, BLOCK
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--nimbus", default=os.path.join(ROOT, "target", "debug", "nimbus"))
    parser.add_argument("--fit", nargs="+",
                        default=["cumulus-front-lit", "cumulus-back-lit", "cumulus-from-below"])
    parser.add_argument("--held-out", nargs="*", default=["cumulus-field", "cumulus-sunset"])
    parser.add_argument("--json", help="write the fit and its residuals here")
    parser.add_argument("--block", type=int, default=2,
                        help="side of the pixel blocks averaged before the fit")
    parser.add_argument("--without", nargs="*", default=[], choices=WEIGHTS,
                        help="weights held at 0 (terms left out of the model)")
    parser.add_argument("--reuse", action="store_true",
                        help="reuse the renders in target/fit-cumulus")
    args = parser.parse_args()
    REUSE, BLOCK = args.reuse, args.block
    out_dir = os.path.join(ROOT, "target", "fit-cumulus")
    os.makedirs(out_dir, exist_ok=True)

    systems = {n: scene_system(args.nimbus, n, out_dir) for n in args.fit + args.held_out}
    x = solve([systems[n] for n in args.fit], args.without)
    x0 = np.array([PAPER[w] for w in WEIGHTS])
    result = {
        "weights_paper": dict(zip(WEIGHTS, x0.tolist())),
        "weights_fitted": dict(zip(WEIGHTS, [round(v, 4) for v in x.tolist()])),
        "block": BLOCK,
        "without": args.without,
        "fit_scenes": args.fit,
        "held_out_scenes": args.held_out,
        "scenes": {},
    }
    print("weights " + "  ".join(f"{w} {a:.3f} -> {b:.3f}" for w, a, b in zip(WEIGHTS, x0, x)))
    for n, s in systems.items():
        role = "fit" if n in args.fit else "held out"
        before, after = relative_rms(s, x0), relative_rms(s, x)
        result["scenes"][n] = {"role": role, "relative_rms_before": before,
                               "relative_rms_after": after, "linearity": s["linearity"],
                               "pixels": s["pixels"]}
        print(f"{n:22s} {role:8s} relative RMS {before:.3f} -> {after:.3f} "
              f"(linearity check {s['linearity']:.1e})")
    if args.json:
        with open(args.json, "w") as f:
            json.dump(result, f, indent=2)
    return 0


if __name__ == "__main__":
    sys.exit(main())
