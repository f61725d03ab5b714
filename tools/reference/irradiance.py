#!/usr/bin/env python3
"""Irradiance meters in a Mitsuba 3 scene: the diffuse light on a horizontal
plane facing up and one facing down at given points.

Each meter traces cosine-weighted rays over its hemisphere through the
scene's own integrator (volumetric path tracing) and takes pi times their
mean radiance. A directional emitter (the sun) cannot be hit by a ray, so
the meters read the diffuse light only: the sky, the cloud layer's light
and the ground's, as nimbus's R_G and its clouds' environment are defined.
With --without-cumulus the cumulus' shapes are left out of the scene (the
light around a cloud, not inside it).

    python3 tools/reference/irradiance.py DIR/scene.xml --point -2513 919 3410 --point -500 600 3500

prints, per point, the irradiance from above and from below (W m^-2, RGB and
Rec. 709 luminance). Used for docs/REALISM.md, "The default scene's cumulus:
the light of the sky and the deck".
"""

import argparse
import os
import re
import sys

import numpy as np

LUMA = np.array([0.2126, 0.7152, 0.0722])


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("scene", help="Mitsuba 3 scene XML (e.g. DIR/scene.xml from `nimbus export`)")
    parser.add_argument("--point", nargs=3, type=float, action="append", required=True,
                        metavar=("X", "Y", "Z"), help="a meter's position, world metres (repeatable)")
    parser.add_argument("--rays", type=int, default=100000, help="rays per hemisphere (default 100000)")
    parser.add_argument("--without-cumulus", action="store_true",
                        help="leave the cumulus' shapes out of the scene")
    parser.add_argument("--variant", default="llvm_ad_rgb", help="Mitsuba variant (default llvm_ad_rgb)")
    parser.add_argument("--seed", type=int, default=1, help="random seed (default 1)")
    args = parser.parse_args()

    import mitsuba as mi

    mi.set_variant(args.variant)
    try:
        xml = open(args.scene, encoding="utf-8").read()
    except OSError as error:
        print(f"irradiance.py: {args.scene}: {error.strerror}", file=sys.stderr)
        return 2
    if args.without_cumulus:
        # A shape whose interior is a cumulus medium (nimbus export names them cumulus_*).
        xml = re.sub(r'<shape type="[a-z]+">(?:(?!</shape>).)*?id="cumulus[^"]*"(?:(?!</shape>).)*?</shape>',
                     "", xml, flags=re.S)
    # The render parameters nimbus's export leaves to the command line.
    xml = xml.replace("$spp", "1").replace("$seed", "0").replace("$max_depth", "-1")
    os.chdir(os.path.dirname(os.path.abspath(args.scene)))
    scene = mi.load_string(xml)
    integrator = scene.integrator()
    rng = np.random.default_rng(args.seed)
    n = args.rays
    print("point (m) | facing | irradiance R, G, B (W m^-2) | luminance")
    for index, point in enumerate(args.point):
        for facing, sign in (("up", 1.0), ("down", -1.0)):
            u1, u2 = rng.random(n), rng.random(n)
            radius, phi = np.sqrt(u1), 2.0 * np.pi * u2
            direction = mi.Vector3f(mi.Float(radius * np.cos(phi)), mi.Float(sign * np.sqrt(1.0 - u1)),
                                    mi.Float(radius * np.sin(phi)))
            origin = mi.Point3f(*(mi.Float(np.full(n, c)) for c in point))
            sampler = mi.load_dict({"type": "independent"})
            sampler.seed(mi.UInt32(args.seed * 1000 + 2 * index + (sign < 0)), n)
            radiance, _, _ = integrator.sample(scene, sampler, mi.Ray3f(o=origin, d=direction))
            irradiance = np.pi * np.array(radiance).mean(axis=1)
            rgb = ", ".join(f"{v:.2f}" for v in irradiance)
            print(f"{point[0]:.0f} {point[1]:.0f} {point[2]:.0f} | {facing} | {rgb} | {irradiance @ LUMA:.2f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
