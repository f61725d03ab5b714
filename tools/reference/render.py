#!/usr/bin/env python3
"""Path-traced reference images: renders a Mitsuba 3 scene XML to a float32 EXR.

The scene is whatever the XML says (e.g. a folder written by
`nimbus export SCENE --mitsuba DIR`: DIR/scene.xml plus its assets, which are
found relative to the XML). The image is rendered in passes of a few samples
per pixel, each pass with its own seed, and the passes are averaged, so a
progress line (pass k of n, elapsed, ETA) can be printed to standard error.

With --halves the passes alternate between two independent halves, written
as OUT_a.exr and OUT_b.exr beside OUT.exr (their mean): the difference of the
halves measures the reference's own noise (the full image's per-pixel
variance is about ((a - b) / 2)^2). OUT.json records the samples, seed,
variant, threads and seconds of the render.

Usage:
    python3 tools/reference/render.py DIR/scene.xml --spp 1024 -o ref.exr
    python3 tools/reference/render.py scene.xml --spp 256 --halves --seed 7 -o ref.exr
"""

import argparse
import os
import sys
import time


def parse_args(argv):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("scene", help="Mitsuba 3 scene XML (e.g. DIR/scene.xml)")
    p.add_argument("-o", "--output", required=True, help="output EXR (float32)")
    p.add_argument("--spp", type=int, default=256, help="samples per pixel in all (default 256)")
    p.add_argument(
        "--spp-per-pass", type=int, default=4,
        help="samples per pixel of one pass (default 4); the total is rounded up to whole passes",
    )
    p.add_argument("--seed", type=int, default=0, help="base seed (default 0)")
    p.add_argument("--threads", type=int, default=0, help="CPU threads (default: all cores)")
    p.add_argument("--variant", default="llvm_ad_rgb", help="Mitsuba variant (default llvm_ad_rgb)")
    p.add_argument("--sensor", type=int, default=0, help="index of the sensor to render (default 0)")
    p.add_argument(
        "--halves", action="store_true",
        help="also write OUT_a.exr and OUT_b.exr, two independent halves of the samples",
    )
    p.add_argument("--quiet", action="store_true", help="no progress lines")
    p.add_argument(
        "-D", "--define", action="append", default=[], metavar="KEY=VALUE",
        help="a scene parameter ($KEY in the XML), may be repeated",
    )
    a = p.parse_args(argv)
    if a.spp < 1 or a.spp_per_pass < 1:
        p.error("--spp and --spp-per-pass must be at least 1")
    if a.seed < 0:
        p.error("--seed must be non-negative")
    if not os.path.isfile(a.scene):
        p.error(f"scene {a.scene}: no such file")
    if not a.output.lower().endswith(".exr"):
        p.error(f"--output {a.output}: must end in .exr")
    return a


def pass_seed(seed, k):
    """A distinct 32-bit seed for pass k of a run with base seed `seed`."""
    return (seed * 0x9E3779B1 + k * 0x85EBCA77 + 1) & 0xFFFFFFFF


def fmt_time(s):
    s = int(round(s))
    return f"{s // 3600}:{s // 60 % 60:02d}:{s % 60:02d}"


def write_exr(mi, path, image, channel_names):
    """Writes a float32 EXR atomically (temp file, then rename)."""
    bitmap = mi.Bitmap(image, channel_names=channel_names) if channel_names else mi.Bitmap(image)
    bitmap = bitmap.convert(component_format=mi.Struct.Type.Float32)
    folder = os.path.dirname(os.path.abspath(path))
    os.makedirs(folder, exist_ok=True)
    tmp = os.path.join(folder, f".{os.path.basename(path)}.{os.getpid()}.tmp.exr")
    try:
        bitmap.write(tmp)
        os.replace(tmp, path)
    finally:
        if os.path.exists(tmp):
            os.remove(tmp)


def main(argv=None):
    a = parse_args(sys.argv[1:] if argv is None else argv)
    import drjit as dr
    import mitsuba as mi

    mi.set_variant(a.variant)
    if a.threads > 0:
        dr.set_thread_count(a.threads)
    params = {}
    for d in a.define:
        if "=" not in d:
            sys.exit(f"render.py: --define {d}: must be KEY=VALUE")
        k, v = d.split("=", 1)
        params[k] = v
    start = time.time()
    scene = mi.load_file(a.scene, **params)
    sensors = scene.sensors()
    if not 0 <= a.sensor < len(sensors):
        sys.exit(f"render.py: --sensor {a.sensor}: the scene has {len(sensors)} sensor(s)")
    sensor = sensors[a.sensor]
    passes = -(-a.spp // a.spp_per_pass)
    if a.halves and passes % 2:
        passes += 1
    spp_total = passes * a.spp_per_pass
    if not a.quiet:
        size = sensor.film().size()
        print(
            f"render.py: {a.scene}: {size[0]}x{size[1]}, {spp_total} spp in {passes} passes "
            f"of {a.spp_per_pass}, variant {a.variant}, {dr.thread_count()} threads, "
            f"loaded in {time.time() - start:.1f} s",
            file=sys.stderr,
        )
    sums = [None, None]  # halves a and b (everything goes to a without --halves)
    counts = [0, 0]
    t0 = time.time()
    for k in range(passes):
        img = mi.render(scene, sensor=a.sensor, spp=a.spp_per_pass, seed=pass_seed(a.seed, k))
        dr.eval(img)
        h = k % 2 if a.halves else 0
        sums[h] = img if sums[h] is None else sums[h] + img
        counts[h] += 1
        dr.eval(sums[h])
        if not a.quiet:
            elapsed = time.time() - t0
            eta = elapsed / (k + 1) * (passes - k - 1)
            print(
                f"render.py: pass {k + 1} of {passes}, elapsed {fmt_time(elapsed)}, ETA {fmt_time(eta)}",
                file=sys.stderr,
                flush=True,
            )
    # Channel names of the film (R, G, B and any AOVs), if Mitsuba gives them.
    try:
        names = list(sensor.film().bitmap().channel_names())
    except Exception:
        names = None
    if names is not None and len(names) != (sums[0].shape[2] if len(sums[0].shape) == 3 else 1):
        names = None
    if names is not None and set(names) >= {"R", "G", "B"} and len(names) == 3:
        names = None  # plain RGB: let Bitmap pick its default
    # Bitmap.write of an EXR hangs when the thread pool has a single thread
    # (Mitsuba 3.9.1 / OpenEXR), so the pool gets a second one for writing.
    if dr.thread_count() < 2:
        dr.set_thread_count(2)
    total = sums[0] if sums[1] is None else sums[0] + sums[1]
    write_exr(mi, a.output, total / (counts[0] + counts[1]), names)
    written = [a.output]
    if a.halves:
        stem = a.output[: -len(".exr")]
        for h, tag in ((0, "a"), (1, "b")):
            write_exr(mi, f"{stem}_{tag}.exr", sums[h] / counts[h], names)
            written.append(f"{stem}_{tag}.exr")
    # What was rendered, beside the image: the samples, seeds and seconds.
    import json
    info = {
        "scene": a.scene,
        "spp": spp_total,
        "spp_per_pass": a.spp_per_pass,
        "halves": a.halves,
        "seed": a.seed,
        "defines": params,
        "variant": a.variant,
        "threads": dr.thread_count(),
        "render_seconds": round(time.time() - t0, 1),
        "total_seconds": round(time.time() - start, 1),
        "mitsuba": mi.__version__,
    }
    with open(a.output[: -len(".exr")] + ".json", "w") as f:
        json.dump(info, f, indent=2)
    if not a.quiet:
        print(
            f"render.py: wrote {', '.join(written)} ({spp_total} spp, {fmt_time(time.time() - start)})",
            file=sys.stderr,
        )


if __name__ == "__main__":
    main()
