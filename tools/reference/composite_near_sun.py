#!/usr/bin/env python3
"""Composes a reference for a view near the sun from a render with the full
phase function and one with the droplets' forward peak truncated (δ-M):
the truncated render where the truncation is accurate, the full one
elsewhere. Two rules, either or both:

- `--sun-angle-deg A`: pixels whose view direction is more than A° from the
  sun take the truncated render (a low sun over a layer: only the pixels
  near the sun need the peak);
- `--body-rim-px N`: the inside of the cloud's body, N pixels in from its
  edge, takes the truncated render (a cloud in front of the sun: the lining
  needs the peak, the thick body's multiply scattered light does not).

    python3 tools/reference/composite_near_sun.py FULL.exr TRUNCATED.exr REALTIME.exr [--sun-angle-deg A] [--body-rim-px N] -o OUT.exr

Why: near the sun the truncation is wrong for light scattered a few times
at small angles (the silver lining), so the full phase function is needed
there; but with it every scattering whose direction falls in the peak
towards the sun carries a weight of up to ~330 sr⁻¹, and in a thick body,
whose light has been scattered hundreds of times, those rare samples stay
fireflies at thousands of samples per pixel. For that multiply scattered
light δ-M is accurate (Wiscombe 1977), which this script checks: it prints
the mean luminance of both renders over the cloud pixels that take the
truncated render, with standard errors from their halves, and refuses to
compose when they differ by more than three standard errors.

The regions are fixed before looking at either render: the angle from the
exported camera's pixel centres and the sun's direction (the full render's
scene.xml), the body from the real-time image's cloud opacity
(`cloud.A` >= 0.99) eroded by N pixels. Each half of
the output takes the same half of each input, so the halves stay
independent. FULL.exr and TRUNCATED.exr are render.py --halves outputs
(with _a, _b and .json beside them). Writes OUT.exr, OUT_a.exr, OUT_b.exr
(float32), OUT.json (both renders' records, the pixel counts, the check)
and OUT_truncated.png (the pixels from the truncated render, white).
"""
import argparse
import json
import os

os.environ.setdefault("DRJIT_LIBLLVM_PATH", "/usr/lib/x86_64-linux-gnu/libLLVM.so.19.1")

# Rec. 709 luminance, as nimbus compare.
LUMINANCE = (0.2126, 0.7152, 0.0722)


def sun_angle_deg(scene_xml, width, height):
    """Angle (degrees) between each pixel centre's ray of the scene's first
    sensor and the direction towards its directional emitter (the sun)."""
    import numpy as np
    import mitsuba as mi

    scene = mi.load_file(scene_xml)
    sensor = scene.sensors()[0]
    suns = [e for e in scene.emitters() if mi.has_flag(e.flags(), mi.EmitterFlags.DeltaDirection)]
    if len(suns) != 1:
        raise SystemExit(f"composite_near_sun.py: {scene_xml} has {len(suns)} directional emitters, not one")
    angles = np.empty((height, width))
    towards_sun = None
    for y in range(height):
        for x in range(width):
            ray, _ = sensor.sample_ray(0.0, 0.5, mi.Point2f((x + 0.5) / width, (y + 0.5) / height), mi.Point2f(0.5, 0.5))
            if towards_sun is None:
                it = mi.Interaction3f()
                it.p = ray.o
                ds, _ = suns[0].sample_direction(it, mi.Point2f(0.5, 0.5))
                towards_sun = np.array(ds.d)
            angles[y, x] = np.degrees(np.arccos(np.clip(np.dot(np.array(ray.d), towards_sun), -1.0, 1.0)))
    return angles


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("full")
    p.add_argument("truncated")
    p.add_argument("realtime", help="nimbus render's EXR of the same view (its cloud.A layer)")
    p.add_argument("--body-rim-px", type=int, help="the body, this many pixels in from the cloud's edge, from the truncated render")
    p.add_argument("--sun-angle-deg", type=float, help="pixels more than this far from the sun from the truncated render")
    p.add_argument("-o", "--output", required=True)
    a = p.parse_args()
    import numpy as np
    import mitsuba as mi

    mi.set_variant("scalar_rgb")
    stems = [f[: -len(".exr")] for f in (a.full, a.truncated)]
    infos = [json.load(open(f"{s}.json")) for s in stems]
    halves = {
        s: [np.array(mi.Bitmap(f"{s}_{t}.exr"), dtype=np.float64)[..., :3] for t in "ab"] for s in stems
    }
    layers = dict(mi.Bitmap(a.realtime).split())
    if "cloud" not in layers:
        raise SystemExit(f"composite_near_sun.py: {a.realtime} has no cloud layer (an EXR of nimbus render)")
    height, width = halves[stems[0]][0].shape[:2]
    opacity = np.array(layers["cloud"]).reshape(height, width, -1)[..., -1]
    if a.body_rim_px is None and a.sun_angle_deg is None:
        raise SystemExit("composite_near_sun.py: give --sun-angle-deg, --body-rim-px or both")
    truncated = np.zeros((height, width), dtype=bool)
    if a.body_rim_px is not None:
        body = opacity >= 0.99
        for _ in range(a.body_rim_px):
            # Erosion by one pixel (4-neighbourhood); the image's border counts as outside.
            inner = body.copy()
            inner[1:, :] &= body[:-1, :]
            inner[:-1, :] &= body[1:, :]
            inner[:, 1:] &= body[:, :-1]
            inner[:, :-1] &= body[:, 1:]
            inner[0, :] = inner[-1, :] = False
            inner[:, 0] = inner[:, -1] = False
            body = inner
        truncated |= body
    if a.sun_angle_deg is not None:
        truncated |= sun_angle_deg(infos[0]["scene"], width, height) > a.sun_angle_deg
    region = truncated & (opacity >= 0.05)
    n = int(region.sum())
    if n == 0:
        raise SystemExit("composite_near_sun.py: no cloud pixel takes the truncated render")
    y = np.array(LUMINANCE)
    check = {}
    for name, s in zip(("full", "truncated"), stems):
        la, lb = (h[region] @ y for h in halves[s])
        # The variance of the mean over the body: the halves' differences'
        # squares over n² (as nimbus compare --halves).
        mean = float(0.5 * (la + lb).mean())
        se = float(np.sqrt(((0.5 * (la - lb)) ** 2).sum()) / n)
        check[name] = {"mean_luminance": mean, "standard_error": se}
    diff = check["truncated"]["mean_luminance"] - check["full"]["mean_luminance"]
    sigma = diff / np.hypot(check["truncated"]["standard_error"], check["full"]["standard_error"])
    check["truncated_over_full"] = check["truncated"]["mean_luminance"] / check["full"]["mean_luminance"]
    check["sigma"] = float(sigma)
    print(
        f"cloud pixels from the truncated render ({n}): full {check['full']['mean_luminance']:.4f} ± {check['full']['standard_error']:.4f}, "
        f"truncated {check['truncated']['mean_luminance']:.4f} ± {check['truncated']['standard_error']:.4f} "
        f"(ratio {check['truncated_over_full']:.4f}, {sigma:+.2f} σ)"
    )
    if abs(sigma) > 3.0:
        raise SystemExit("composite_near_sun.py: the renders disagree there by more than 3 σ; not composed")
    out = a.output[: -len(".exr")]
    mask = truncated[..., None]
    composed = []
    for i, tag in enumerate("ab"):
        image = np.where(mask, halves[stems[1]][i], halves[stems[0]][i])
        composed.append(image)
        mi.Bitmap(image.astype(np.float32)).write(f"{out}_{tag}.exr")
    mi.Bitmap((0.5 * (composed[0] + composed[1])).astype(np.float32)).write(a.output)
    picture = np.repeat((truncated * 255).astype(np.uint8)[..., None], 3, axis=2)
    mi.Bitmap(picture, pixel_format=mi.Bitmap.PixelFormat.RGB).write(f"{out}_truncated.png")
    info = {
        "composite": "δ-M truncated render where the rules put it, the full phase function elsewhere",
        "body_rim_px": a.body_rim_px,
        "sun_angle_deg": a.sun_angle_deg,
        "truncated_pixels": int(truncated.sum()),
        "truncated_cloud_pixels": n,
        "check": check,
        "full": infos[0],
        "truncated": infos[1],
        # The record's fields of a plain render.py output: samples per pixel
        # of the full render (the one the picture's lining comes from),
        # seconds of both.
        "spp": infos[0]["spp"],
        "seed": infos[0]["seed"],
        "threads": infos[0]["threads"],
        "variant": infos[0]["variant"],
        "render_seconds": round(infos[0]["render_seconds"] + infos[1]["render_seconds"], 1),
        "total_seconds": round(infos[0]["total_seconds"] + infos[1]["total_seconds"], 1),
    }
    with open(f"{out}.json", "w") as f:
        json.dump(info, f, indent=2)


if __name__ == "__main__":
    main()
