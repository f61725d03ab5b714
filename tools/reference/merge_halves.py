#!/usr/bin/env python3
"""Merges two independent renders of the same scene, each as two halves
(render.py --halves with different --seed), into one of their summed
samples: each half is the mean of the two renders' halves weighted by their
samples, so the halves stay independent and the noise falls as if the
samples had been rendered at once.

    python3 tools/reference/merge_halves.py FIRST.exr SECOND.exr -o OUT.exr

FIRST.exr and SECOND.exr are render.py outputs (with FIRST_a.exr,
FIRST_b.exr and FIRST.json beside them, the same for SECOND). Writes
OUT.exr, OUT_a.exr, OUT_b.exr (float32) and OUT.json (the samples and
seconds summed, both seeds listed).
"""
import argparse
import json
import os

os.environ.setdefault("DRJIT_LIBLLVM_PATH", "/usr/lib/x86_64-linux-gnu/libLLVM.so.19.1")


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("first")
    p.add_argument("second")
    p.add_argument("-o", "--output", required=True)
    a = p.parse_args()
    import numpy as np
    import mitsuba as mi

    mi.set_variant("scalar_rgb")
    stems = [f[: -len(".exr")] for f in (a.first, a.second)]
    infos = [json.load(open(f"{s}.json")) for s in stems]
    for s, info in zip(stems, infos):
        if not info.get("halves"):
            raise SystemExit(f"merge_halves.py: {s}.exr was not rendered with --halves")
    if infos[0]["seed"] == infos[1]["seed"]:
        raise SystemExit("merge_halves.py: both renders have the same seed: their samples are not independent")
    weights = np.array([i["spp"] for i in infos], dtype=np.float64)
    weights /= weights.sum()
    out = a.output[: -len(".exr")]
    halves = []
    for tag in "ab":
        images = [np.array(mi.Bitmap(f"{s}_{tag}.exr"), dtype=np.float64) for s in stems]
        if images[0].shape != images[1].shape:
            raise SystemExit("merge_halves.py: the renders differ in size")
        merged = weights[0] * images[0] + weights[1] * images[1]
        halves.append(merged)
        mi.Bitmap(merged.astype(np.float32)).write(f"{out}_{tag}.exr")
    mi.Bitmap((0.5 * (halves[0] + halves[1])).astype(np.float32)).write(a.output)
    info = dict(infos[0])
    info["spp"] = sum(i["spp"] for i in infos)
    info["seed"] = [i["seed"] for i in infos]
    info["render_seconds"] = round(sum(i["render_seconds"] for i in infos), 1)
    info["total_seconds"] = round(sum(i["total_seconds"] for i in infos), 1)
    info["merged_from"] = [f"{s}.exr" for s in stems]
    with open(f"{out}.json", "w") as f:
        json.dump(info, f, indent=2)


if __name__ == "__main__":
    main()
