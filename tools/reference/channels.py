#!/usr/bin/env python3
"""Combines three path-traced renders of one scene, each right in one
channel, into one reference: channel c of render c (red, green, blue).

Mitsuba's grid media and tabulated phase functions are not spectral, so
what changes with the wavelength is exported once per channel and chosen
by a scene parameter: `nimbus export --mitsuba --air` writes the air as one
grey medium per channel (`$air`), `--phase-per-channel` the droplets' phase
function at each channel's wavelength (`$phase`, the diffraction peak's
width goes with the wavelength). Render each with tools/reference/render.py
--halves (-D air=r, ... or -D phase=r, ...), then

    python3 tools/reference/channels.py R.exr G.exr B.exr -o OUT.exr [--what TEXT]

writes OUT.exr, OUT_a.exr and OUT_b.exr (half floats, as the suite's
references; each half from the same half of each render, so the halves
stay independent) and OUT.json (the three renders' records).
"""
import argparse
import json
import os

os.environ.setdefault("DRJIT_LIBLLVM_PATH", "/usr/lib/x86_64-linux-gnu/libLLVM.so.19.1")


def load(path, channels=("R", "G", "B")):
    """The named channels of an EXR (e.g. "R", "Z", "cloud.A") as float64
    arrays, by name."""
    import numpy as np
    import mitsuba as mi

    bitmap = mi.Bitmap(path)
    names = [f.name for f in bitmap.struct_()]
    data = np.array(bitmap, dtype=np.float64)
    if data.ndim == 2:
        data = data[:, :, None]
    out = {}
    for name in channels:
        if name not in names:
            raise SystemExit(f"{path}: no channel {name}")
        out[name] = data[:, :, names.index(name)]
    return out


def combine(red, green, blue, output, what):
    """Writes OUT.exr and its halves, channel c from render c, and OUT.json."""
    import numpy as np
    import mitsuba as mi

    mi.set_variant("scalar_rgb")
    if not output.endswith(".exr"):
        raise SystemExit(f"channels.py: -o {output}: must end in .exr")
    stems = []
    for path in (red, green, blue):
        if not path.endswith(".exr"):
            raise SystemExit(f"channels.py: {path}: must be a render.py output (.exr)")
        stems.append(path[: -len(".exr")])
    infos = [json.load(open(f"{s}.json")) for s in stems]
    out_stem = output[: -len(".exr")]
    for suffix in ("", "_a", "_b"):
        planes = [load(f"{s}{suffix}.exr", ("RGB"[c],))["RGB"[c]] for c, s in enumerate(stems)]
        image = np.stack(planes, axis=-1).astype(np.float16)
        mi.Bitmap(image, mi.Bitmap.PixelFormat.RGB).write(f"{out_stem}{suffix}.exr")
    record = {
        "channels": f"channel c of render c (r, g, b): {what}",
        "renders": infos,
        "halves": True,
        # The fields of a plain render.py output, for the scripts that read
        # one (composite_near_sun.py, suite.sh): the samples and seeds per
        # channel, the seconds of all three.
        "spp": [i.get("spp") for i in infos],
        "seed": [i.get("seed") for i in infos],
        "threads": infos[0].get("threads"),
        "variant": infos[0].get("variant"),
        "render_seconds": round(sum(i.get("render_seconds", 0.0) for i in infos), 1),
        "total_seconds": round(sum(i.get("total_seconds", 0.0) for i in infos), 1),
        "seconds": round(sum(i.get("total_seconds", i.get("seconds", 0.0)) for i in infos), 1),
    }
    json.dump(record, open(f"{out_stem}.json", "w"), indent=2)
    print(f"channels.py: wrote {output} and its halves")


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("red")
    p.add_argument("green")
    p.add_argument("blue")
    p.add_argument("-o", "--output", required=True)
    p.add_argument("--what", default="one render per channel", help="what differs per channel, for the record")
    a = p.parse_args()
    combine(a.red, a.green, a.blue, a.output, a.what)


if __name__ == "__main__":
    main()
