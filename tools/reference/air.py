#!/usr/bin/env python3
"""The air in front of what nimbus draws, against a reference with air
(docs/REALISM.md, "The air under a cloud layer").

`nimbus export --mitsuba --air` writes the air as one grey medium per
channel (the scene's $air = r, g or b; see the exporter's notes); each is
path-traced on its own and the reference takes channel c of render c.

    python3 tools/reference/air.py combine R.exr G.exr B.exr -o OUT.exr
        OUT.exr, OUT_a.exr, OUT_b.exr (half floats; halves kept independent)
        and OUT.json from three render.py --halves outputs (channels.py).
    python3 tools/reference/air.py measure REALTIME.exr... --halves A.exr B.exr
        Prints one JSON document: for each real-time EXR (nimbus render -o
        x.exr, its Z and cloud.A layers give the masks), over the terrain
        pixels (no cloud in front, depth known) in bands of distance and over
        the cloud pixels: the mean luminance ratio nimbus / reference, the
        red/blue ratio, and the block error (noise-free relative RMSE over
        4x4 blocks, the mean of (N - A)(N - B) over blocks with the
        reference's halves A and B, over the reference's mean luminance).
"""
import argparse
import json
import os

from channels import combine as combine_channels, load

os.environ.setdefault("DRJIT_LIBLLVM_PATH", "/usr/lib/x86_64-linux-gnu/libLLVM.so.19.1")

LUMINANCE = (0.2126, 0.7152, 0.0722)
BANDS_M = [(0.0, 2000.0), (2000.0, 5000.0), (5000.0, 10000.0), (10000.0, 40000.0)]
BLOCK = 4


def combine(a):
    combine_channels(a.red, a.green, a.blue, a.output, "one grey air medium per channel")


def luminance(image):
    return sum(w * image[c] for w, c in zip(LUMINANCE, "RGB"))


def block_error(n, ra, rb, mask):
    """Noise-free relative RMSE of luminance over BLOCK-sized blocks whose
    pixels are at least half in the mask (means over the masked pixels)."""
    import numpy as np

    h, w = mask.shape
    terms, refs = [], []
    for y in range(0, h - BLOCK + 1, BLOCK):
        for x in range(0, w - BLOCK + 1, BLOCK):
            m = mask[y : y + BLOCK, x : x + BLOCK]
            if m.sum() < BLOCK * BLOCK / 2:
                continue
            sel = lambda img: img[y : y + BLOCK, x : x + BLOCK][m].mean()
            nb, ab, bb = sel(n), sel(ra), sel(rb)
            terms.append((nb - ab) * (nb - bb))
            refs.append(0.5 * (ab + bb))
    if not terms:
        return None
    return float(np.sqrt(max(np.mean(terms), 0.0)) / np.mean(refs))


def summary(n, ra, rb, mask):
    import numpy as np

    if mask.sum() == 0:
        return None
    ref = {c: 0.5 * (ra[c] + rb[c]) for c in "RGB"}
    ln, lr = luminance(n), luminance(ref)
    return {
        "pixels": int(mask.sum()),
        "luminance_ratio": float(ln[mask].mean() / lr[mask].mean()),
        "red_blue_ratio": float(
            (n["R"][mask].mean() / n["B"][mask].mean()) / (ref["R"][mask].mean() / ref["B"][mask].mean())
        ),
        "reference_red_blue": float(ref["R"][mask].mean() / ref["B"][mask].mean()),
        "reference_luminance": float(lr[mask].mean()),
        "block_error": block_error(ln, luminance(ra), luminance(rb), mask),
    }


def measure(a):
    import numpy as np
    import mitsuba as mi

    mi.set_variant("scalar_rgb")
    ra, rb = load(a.halves[0]), load(a.halves[1])
    result = {}
    for path in a.realtime:
        n = load(path, ("R", "G", "B", "Z", "cloud.A"))
        clear = n["cloud.A"] < 0.05
        depth = n["Z"]
        terrain = clear & np.isfinite(depth) & (depth > 0.0) & (depth < 1.0e6)
        rows = {}
        for lo, hi in BANDS_M:
            rows[f"terrain {lo / 1000:.0f}-{hi / 1000:.0f} km"] = summary(
                n, ra, rb, terrain & (depth >= lo) & (depth < hi)
            )
        rows["terrain, all"] = summary(n, ra, rb, terrain)
        rows["cloud"] = summary(n, ra, rb, n["cloud.A"] >= 0.05)
        result[path] = rows
    print(json.dumps(result, indent=2))


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    sub = p.add_subparsers(dest="command", required=True)
    c = sub.add_parser("combine")
    c.add_argument("red")
    c.add_argument("green")
    c.add_argument("blue")
    c.add_argument("-o", "--output", required=True)
    m = sub.add_parser("measure")
    m.add_argument("realtime", nargs="+")
    m.add_argument("--halves", nargs=2, required=True)
    a = p.parse_args()
    combine(a) if a.command == "combine" else measure(a)


if __name__ == "__main__":
    main()
