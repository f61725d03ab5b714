#!/usr/bin/env python3
"""A homogeneous cloud slab path-traced by Mitsuba 3 against `nimbus slab --method monte-carlo`.

The slab: a wide flat `cube` (width W = 1000 H, thickness H = 1) with a `null`
BSDF and a `homogeneous` interior, σ_t = τ / H, the albedo nimbus reports, and
the phase function nimbus traces: Mitsuba's `hg` for --phase hg:G, `tabphase`
for --phase mie (nimbus's droplet phase function at 550 nm, from
`nimbus optics dsd --csv`). Lit by a `directional` emitter of irradiance 1
(normal to the beam) and nothing else; `radiancemeter` sensors look at the
middle of the top (reflection) or of the bottom (transmission) from the view
direction; `volpath` with no Russian roulette and no practical depth limit.
Each radiance is the mean of --runs independent renders (distinct seeds) of
--spp samples; its standard error is their standard deviation over √runs.

Normalisation: nimbus reports radiance per unit incident flux on the top
(the horizontal irradiance μ₀ E), Mitsuba radiance for E = 1 normal to the
beam, so L_nimbus = L_mitsuba / μ₀ with μ₀ = cos(sun zenith). The direct
beam (order 0) is in neither: the view directions avoid the sun's.

Writes a JSON file (default crates/nimbus-cli/tests/data/slab_mitsuba.json)
with both tools' numbers per case, and prints a table.

Usage:
    python3 tools/reference/slab.py                       # the stored cases
    python3 tools/reference/slab.py --runs 8 --spp 65536  # quicker, noisier
"""

import argparse
import bisect
import json
import math
import os
import shlex
import statistics
import subprocess
import sys
import tempfile
import time

# (optical depth, phase, sun zenith, [(view zenith, relative azimuth), ...],
# Mitsuba runs as a multiple of --runs); view zenith < 90: reflection, > 90:
# transmission (nimbus's convention). The thin HG slabs are cheap (about 20×
# faster per sample than the Mie ones), so they get more runs.
DEFAULT_CASES = [
    (10.0, "mie", 0.0, [(0.0, 0.0), (60.0, 0.0), (150.0, 0.0), (120.0, 0.0)], 1),
    (10.0, "mie", 60.0, [(0.0, 0.0), (45.0, 180.0), (180.0, 0.0), (140.0, 180.0)], 1),
    (2.0, "hg:0.85", 0.0, [(30.0, 0.0), (150.0, 0.0)], 4),
    (2.0, "hg:0.85", 60.0, [(30.0, 90.0), (140.0, 180.0)], 4),
]

SLAB_THICKNESS = 1.0
SLAB_WIDTH = 1000.0
WAVELENGTH_NM = 550.0


def here(*parts):
    return os.path.join(os.path.dirname(os.path.abspath(__file__)), *parts)


REPO = os.path.normpath(here("..", ".."))


def parse_args(argv):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--nimbus", default=os.path.join(REPO, "target", "debug", "nimbus"),
                   help="the nimbus binary (default target/debug/nimbus)")
    p.add_argument("-o", "--output",
                   default=os.path.join(REPO, "crates", "nimbus-cli", "tests", "data", "slab_mitsuba.json"),
                   help="JSON file to write")
    p.add_argument("--spp", type=int, default=131072, help="samples per Mitsuba run (default 131072)")
    p.add_argument("--runs", type=int, default=32, help="independent Mitsuba runs per case (default 32)")
    p.add_argument("--seed", type=int, default=1, help="base seed of the Mitsuba runs (default 1)")
    p.add_argument("--photons", type=int, default=8_000_000,
                   help="nimbus photons of the reference comparison (default 8000000)")
    p.add_argument("--nimbus-seed", type=int, default=1, help="nimbus seed (default 1)")
    p.add_argument("--test-photons", type=int, default=200_000,
                   help="photons of the CI test's nimbus run, recorded and checked (default 200000)")
    p.add_argument("--test-seed", type=int, default=1, help="seed of the CI test's nimbus run (default 1)")
    p.add_argument("--tabphase-nodes", type=int, default=(1 << 20) + 1,
                   help="tabphase nodes, uniform in cos Θ over [-1, 1] (default 2^20 + 1)")
    p.add_argument("--threads", type=int, default=0, help="Mitsuba CPU threads (default: all cores)")
    p.add_argument("--variant", default="llvm_ad_rgb", help="Mitsuba variant (default llvm_ad_rgb)")
    p.add_argument("--only", default=None,
                   help="run only the case groups whose phase is this string (e.g. mie)")
    p.add_argument("--sun", type=float, default=None,
                   help="run only the case groups with this sun zenith angle, degrees")
    p.add_argument("--no-tabphase-check", action="store_true",
                   help="skip rendering the hg:G cases a second time through tabphase "
                        "(the check of the tabphase convention used for mie)")
    a = p.parse_args(argv)
    if a.spp < 1 or a.runs < 2:
        p.error("--spp must be at least 1 and --runs at least 2")
    if not os.access(a.nimbus, os.X_OK):
        p.error(f"--nimbus {a.nimbus}: not an executable (build it with cargo build -p nimbus-sky)")
    return a


# ---------------------------------------------------------------- nimbus


def run_nimbus(nimbus, args):
    t = time.time()
    out = subprocess.run([nimbus] + args, check=True, capture_output=True, text=True)
    return json.loads(out.stdout), time.time() - t


def nimbus_slab(a, tau, phase, sun, vz, phi, photons, seed):
    args = ["slab", "--optical-depth", repr(tau), "--sun-zenith-deg", repr(sun),
            "--view-zenith-deg", repr(vz), "--relative-azimuth-deg", repr(phi),
            "--phase", phase, "--method", "monte-carlo", "--photons", str(photons),
            "--seed", str(seed), "--json"]
    report, seconds = run_nimbus(a.nimbus, args)
    return report, seconds, "nimbus " + " ".join(shlex.quote(x) for x in args)


def computation_angles(forward_peak_deg=5.0):
    """The tracer's Mie angle grid (nimbus_physics::optics::tables::computation_angles)."""
    fine_end = min(2.0 * forward_peak_deg, 30.0)
    angles = []
    i = 0
    while i * 0.05 < fine_end:
        angles.append(i * 0.05)
        i += 1
    i = 0
    while fine_end + i * 0.25 <= 180.0:
        angles.append(fine_end + i * 0.25)
        i += 1
    if angles[-1] < 180.0:
        angles.append(180.0)
    return angles


def nimbus_mie_table(a):
    """nimbus's droplet phase function at 550 nm on the tracer's angle grid.

    `nimbus slab --phase mie` computes it with the default droplets (r_e 7 µm,
    γ 2, 300 cm⁻³), the grid `computation_angles(5°)` (0.05° to 10°, then
    0.25°) and tolerance 1e-3; `nimbus optics dsd` is asked for the same
    droplets on a 0.05° grid at the same tolerance and the tracer's nodes are
    kept (between nodes both tools take p linear in θ).
    """
    with tempfile.TemporaryDirectory() as d:
        csv = os.path.join(d, "phase.csv")
        args = ["optics", "dsd", "--wavelength-nm", str(int(WAVELENGTH_NM)), "--angle-step-deg", "0.05",
                "--tolerance", "1e-3", "--csv", csv]
        subprocess.run([a.nimbus] + args, check=True, capture_output=True, text=True)
        rows = [line.split(",") for line in open(csv).read().split("\n")[1:] if line.strip()]
    full = {round(float(r[0]) * 20): float(r[1]) for r in rows}
    angles = computation_angles()
    values = [full[round(x * 20)] for x in angles]
    return angles, values, "nimbus " + " ".join(args[:-1] + ["FILE"])


# ---------------------------------------------------------------- phase tables


class ThetaTable:
    """p(θ) linear in θ between nodes (nimbus's PhaseTable), normalised to 1 over the sphere."""

    def __init__(self, angles_deg, values):
        self.a = [math.radians(x) for x in angles_deg]
        self.v = list(values)
        norm = sum(self._cone(i) for i in range(1, len(self.a)))
        self.v = [x / norm for x in self.v]

    def _cone(self, i, weight=lambda mu: 1.0):
        # ∫ 2π p sin θ dθ over interval i by 8-point Gauss–Legendre (exact enough).
        a0, a1 = self.a[i - 1], self.a[i]
        total = 0.0
        for x, w in GAUSS8:
            t = 0.5 * (x + 1.0)
            th = a0 + t * (a1 - a0)
            p = self.v[i - 1] + t * (self.v[i] - self.v[i - 1])
            total += w * 0.5 * (a1 - a0) * 2.0 * math.pi * p * math.sin(th) * weight(math.cos(th))
        return total

    def asymmetry(self):
        return sum(self._cone(i, lambda mu: mu) for i in range(1, len(self.a)))

    def at_cos(self, mu):
        th = math.acos(max(-1.0, min(1.0, mu)))
        i = min(max(bisect.bisect_right(self.a, th), 1), len(self.a) - 1)
        t = (th - self.a[i - 1]) / (self.a[i] - self.a[i - 1])
        return self.v[i - 1] + t * (self.v[i] - self.v[i - 1])


def _gauss8():
    xs = [0.1834346424956498, 0.5255324099163290, 0.7966664774136267, 0.9602898564975363]
    ws = [0.3626837833783620, 0.3137066458778873, 0.2223810344533745, 0.1012285362903763]
    return [(s * x, w) for x, w in zip(xs, ws) for s in (-1.0, 1.0)]


GAUSS8 = _gauss8()


def hg(g, mu):
    return (1 - g * g) / (4 * math.pi * (1 + g * g - 2 * g * mu) ** 1.5)


def tabphase_values(p_of_mu, nodes):
    """Mitsuba's `tabphase` convention: `values` at cos Θ = -1 + 2k/(nodes-1),
    k = 0 … nodes-1 (Θ the scattering angle, cos Θ = 1 forward), linear in
    cos Θ between them, normalised by Mitsuba (any scale). Returns the values
    and the asymmetry g of that piecewise-linear function."""
    h = 2.0 / (nodes - 1)
    mus = [-1.0 + k * h for k in range(nodes)]
    mus[-1] = 1.0
    v = [p_of_mu(m) for m in mus]
    # ∫ p dμ and ∫ μ p dμ of the linear interpolant, exactly.
    i0 = sum(0.5 * h * (v[k] + v[k + 1]) for k in range(nodes - 1))
    i1 = sum(h * (v[k] * (2 * mus[k] + mus[k + 1]) + v[k + 1] * (mus[k] + 2 * mus[k + 1])) / 6.0
             for k in range(nodes - 1))
    return v, i1 / i0


# ---------------------------------------------------------------- Mitsuba


def view_vector(vz, phi):
    """nimbus's view direction (slab → viewer) in Mitsuba's frame, z up, the sun on the −x side."""
    s, c = math.sin(math.radians(vz)), math.cos(math.radians(vz))
    return [-s * math.cos(math.radians(phi)), s * math.sin(math.radians(phi)), c]


def mitsuba_scene(mi, tau, albedo, phase_dict, sun, views):
    st, ct = math.sin(math.radians(sun)), math.cos(math.radians(sun))
    h, w = SLAB_THICKNESS, SLAB_WIDTH
    scene = {
        "type": "scene",
        # No Russian roulette (rr_depth = max_depth) and no practical depth limit.
        "integrator": {"type": "volpath", "max_depth": 1_000_000, "rr_depth": 1_000_000},
        "sun": {"type": "directional", "direction": [st, 0.0, -ct],
                "irradiance": {"type": "rgb", "value": 1.0}},
        "slab": {
            "type": "cube",
            "to_world": mi.ScalarTransform4f().translate([0.0, 0.0, -0.5 * h]).scale([0.5 * w, 0.5 * w, 0.5 * h]),
            "bsdf": {"type": "null"},
            "interior": {"type": "homogeneous", "sigma_t": tau / h, "albedo": albedo,
                         "phase": phase_dict},
        },
    }
    for i, (vz, phi) in enumerate(views):
        v = view_vector(vz, phi)
        target = [0.0, 0.0, 0.0] if v[2] > 0 else [0.0, 0.0, -h]
        scene[f"meter_{i:02d}"] = {
            "type": "radiancemeter",
            "origin": [target[k] + v[k] for k in range(3)],
            "direction": [-x for x in v],
            "film": {"type": "hdrfilm", "width": 1, "height": 1, "pixel_format": "rgb",
                     "rfilter": {"type": "box"}},
            "sampler": {"type": "independent"},
        }
    return mi.load_dict(scene)


def run_seed(base, group, view, run):
    return (base * 0x9E3779B1 + group * 0x85EBCA77 + view * 0xC2B2AE3D + run * 0x27D4EB2F + 1) & 0xFFFFFFFF


def mitsuba_radiance(mi, scene, sensor, a, runs, group, label):
    xs = []
    t0 = time.time()
    for r in range(runs):
        img = mi.render(scene, sensor=sensor, spp=a.spp, seed=run_seed(a.seed, group, sensor, r))
        rgb = [float(x) for x in img.array]
        xs.append(sum(rgb) / len(rgb))
        el = time.time() - t0
        print(f"slab.py: {label}: run {r + 1} of {runs}, elapsed {el:.0f} s, "
              f"ETA {el / (r + 1) * (runs - r - 1):.0f} s", file=sys.stderr, flush=True)
    return statistics.mean(xs), statistics.stdev(xs) / math.sqrt(len(xs)), time.time() - t0


# ---------------------------------------------------------------- main


def main(argv=None):
    a = parse_args(sys.argv[1:] if argv is None else argv)
    import drjit as dr
    import mitsuba as mi

    mi.set_variant(a.variant)
    if a.threads > 0:
        dr.set_thread_count(a.threads)
    start = time.time()
    # The command that regenerates the file (the binary's path and the default output left out).
    shown, skip = [], False
    for x in (argv or sys.argv[1:]):
        if skip:
            skip = False
        elif x in ("--nimbus", "-o", "--output"):
            skip = True
        elif not x.startswith(("--nimbus=", "--output=")):
            shown.append(x)
    command = " ".join(["python3 tools/reference/slab.py"] + [shlex.quote(x) for x in shown])
    nimbus_version = subprocess.run([a.nimbus, "--version"], capture_output=True, text=True).stdout.strip()
    cases_out = []
    phases_out = {}
    mie_table = None
    for group, (tau, phase, sun, views, runs_factor) in enumerate(DEFAULT_CASES):
        if (a.only is not None and phase != a.only) or (a.sun is not None and sun != a.sun):
            continue
        # nimbus first: its albedo, and the phase function it traces.
        probe, _, _ = nimbus_slab(a, tau, phase, sun, views[0][0], views[0][1], 4096, 1)
        albedo = probe["single_scattering_albedo"]
        if phase == "mie":
            if mie_table is None:
                angles, values, how = nimbus_mie_table(a)
                table = ThetaTable(angles, values)
                vals, g_mu = tabphase_values(table.at_cos, a.tabphase_nodes)
                mie_table = {"type": "tabphase", "values": ",".join(f"{x:.8e}" for x in vals)}
                phases_out["mie"] = {
                    "source": how,
                    "tracer_grid": "0.05 deg to 10 deg, then 0.25 deg to 180 deg (computation_angles(5))",
                    "asymmetry_theta_linear": table.asymmetry(),
                    "mitsuba": f"tabphase, {a.tabphase_nodes} values at cos = -1 + 2k/{a.tabphase_nodes - 1}",
                    "asymmetry_tabphase": g_mu,
                }
                print(f"slab.py: mie phase: g = {table.asymmetry():.6f} (linear in θ), "
                      f"{g_mu:.6f} (tabphase, {a.tabphase_nodes} nodes)", file=sys.stderr)
            phase_dict = mie_table
        elif phase.startswith("hg:"):
            g = float(phase[3:])
            phase_dict = {"type": "hg", "g": g}
            phases_out[phase] = {"mitsuba": f"hg, g = {g}"}
            if not a.no_tabphase_check:
                vals, g_mu = tabphase_values(lambda m: hg(g, m), a.tabphase_nodes)
                check_dict = {"type": "tabphase", "values": ",".join(f"{x:.8e}" for x in vals)}
                phases_out[phase]["tabphase_check"] = (
                    f"the same cases rendered with HG tabulated for tabphase ({a.tabphase_nodes} values, "
                    f"g = {g_mu:.7f}): case['mitsuba_tabphase']")
        else:
            phase_dict = {"type": "isotropic"}
            phases_out[phase] = {"mitsuba": "isotropic"}
        scene = mitsuba_scene(mi, tau, albedo, phase_dict, sun, views)
        check_scene = None
        if phase.startswith("hg:") and not a.no_tabphase_check:
            check_scene = mitsuba_scene(mi, tau, albedo, check_dict, sun, views)
        mu0 = math.cos(math.radians(sun))
        for i, (vz, phi) in enumerate(views):
            label = f"tau {tau:g} {phase} sun {sun:g} view {vz:g}/{phi:g}"
            runs = a.runs * runs_factor
            m_raw, m_se_raw, m_seconds = mitsuba_radiance(mi, scene, i, a, runs, group, label)
            ref, ref_seconds, ref_cmd = nimbus_slab(a, tau, phase, sun, vz, phi, a.photons * runs_factor,
                                                    a.nimbus_seed)
            test, test_seconds, test_cmd = nimbus_slab(a, tau, phase, sun, vz, phi, a.test_photons, a.test_seed)
            m, m_se = m_raw / mu0, m_se_raw / mu0
            n, n_se = ref["radiance"]["total"], ref["std_error"]["radiance"]["total"]
            t, t_se = test["radiance"]["total"], test["std_error"]["radiance"]["total"]
            z = (n - m) / math.hypot(n_se, m_se)
            zt = (t - m) / math.hypot(t_se, m_se)
            case = {
                "optical_depth": tau,
                "sun_zenith_deg": sun,
                "view_zenith_deg": vz,
                "relative_azimuth_deg": phi,
                "side": "reflection" if vz < 90 else "transmission",
                "phase": phase,
                "single_scattering_albedo": albedo,
                "scattering_angle_deg": ref["scattering_angle_deg"],
                "mitsuba": {
                    "radiance": m, "std_error": m_se,
                    "radiance_unit_irradiance": m_raw, "std_error_unit_irradiance": m_se_raw,
                    "spp": a.spp * runs, "runs": runs, "seconds": round(m_seconds, 1),
                },
                "nimbus": {"photons": ref["photons"], "seed": a.nimbus_seed, "radiance": n, "std_error": n_se,
                           "seconds": round(ref_seconds, 2), "command": ref_cmd},
                "nimbus_test": {"photons": test["photons"], "seed": a.test_seed, "radiance": t,
                                "std_error": t_se, "seconds": round(test_seconds, 2), "command": test_cmd},
                "difference_in_sigma": z,
                "agrees_within_3_sigma": abs(z) < 3.0,
                "test_difference_in_sigma": zt,
                "test_agrees_within_3_sigma": abs(zt) < 3.0,
            }
            if check_scene is not None:
                c_raw, c_se_raw, c_seconds = mitsuba_radiance(mi, check_scene, i, a, runs, group + 100,
                                                              label + " (tabphase)")
                zc = (c_raw - m_raw) / math.hypot(c_se_raw, m_se_raw)
                case["mitsuba_tabphase"] = {"radiance": c_raw / mu0, "std_error": c_se_raw / mu0,
                                            "difference_from_hg_in_sigma": zc}
                print(f"slab.py: {label}: mitsuba tabphase {c_raw / mu0:.6f} ± {c_se_raw / mu0:.6f} "
                      f"({zc:+.2f} σ from hg)", file=sys.stderr, flush=True)
            cases_out.append(case)
            print(f"slab.py: {label}: mitsuba {m:.6f} ± {m_se:.6f}, nimbus {n:.6f} ± {n_se:.6f} "
                  f"({z:+.2f} σ); test run {t:.6f} ± {t_se:.6f} ({zt:+.2f} σ, {test_seconds:.1f} s)",
                  file=sys.stderr, flush=True)
    test_seconds = sum(c["nimbus_test"]["seconds"] for c in cases_out)
    doc = {
        "description": (
            "Radiance leaving a homogeneous plane-parallel cloud slab lit by the sun, path-traced by "
            "Mitsuba 3 (volpath, wide null-BSDF box with a homogeneous medium, directional emitter, "
            "radiancemeters) and by nimbus's slab tracer (nimbus slab --method monte-carlo, local estimate)."
        ),
        "normalisation": (
            "radiance (1/sr) per unit incident flux on the slab's top, nimbus's convention: "
            "radiance = mitsuba radiance for a directional emitter of irradiance 1 (normal to the beam) "
            "divided by cos(sun zenith). The direct beam is excluded from both."
        ),
        "tolerance": "|nimbus - mitsuba| < 3 sqrt(se_nimbus^2 + se_mitsuba^2)",
        "regenerate": command + "  (DRJIT_LIBLLVM_PATH set, see tools/reference/README.md)",
        "nimbus_version": nimbus_version,
        "mitsuba_version": mi.__version__,
        "drjit_version": dr.__version__,
        "mitsuba_variant": a.variant,
        "mitsuba_scene": {
            "slab": f"cube scaled to {SLAB_WIDTH:g} x {SLAB_WIDTH:g} x {SLAB_THICKNESS:g}, top at z = 0, "
                    "bsdf null, interior homogeneous sigma_t = optical_depth / thickness",
            "integrator": "volpath, max_depth = rr_depth = 1000000 (no Russian roulette)",
            "sensors": "radiancemeter 1 m from the middle of the top (reflection) or bottom (transmission)",
            "runs_per_case": f"{a.runs} (hg cases: {4 * a.runs})", "spp_per_run": a.spp,
        },
        "phases": phases_out,
        "test": {
            "photons": a.test_photons, "seed": a.test_seed,
            "photons_traced": -(-a.test_photons // 4096) * 4096,
            "debug_build_seconds_all_cases": round(test_seconds, 1),
            "note": "--photons is rounded up to whole batches of 4096 (photons_traced); "
                    "nimbus_test holds what `nimbus slab` printed with these photons and seed "
                    "(target/debug build, 2 cores); the test compares its radiance with mitsuba.radiance "
                    "within 3 combined standard errors",
        },
        "seconds_total": round(time.time() - start, 1),
        "cases": cases_out,
    }
    os.makedirs(os.path.dirname(os.path.abspath(a.output)), exist_ok=True)
    tmp = a.output + ".tmp"
    with open(tmp, "w") as f:
        json.dump(doc, f, indent=1)
        f.write("\n")
    os.replace(tmp, a.output)
    print(f"\n{'tau':>4} {'phase':>8} {'sun':>4} {'view':>9} {'mitsuba':>20} {'nimbus':>20} {'sigma':>6}")
    for c in cases_out:
        print(f"{c['optical_depth']:4g} {c['phase']:>8} {c['sun_zenith_deg']:4g} "
              f"{c['view_zenith_deg']:5g}/{c['relative_azimuth_deg']:<3g} "
              f"{c['mitsuba']['radiance']:10.6f} ± {c['mitsuba']['std_error']:.6f} "
              f"{c['nimbus']['radiance']:10.6f} ± {c['nimbus']['std_error']:.6f} "
              f"{c['difference_in_sigma']:+6.2f}")
    print(f"slab.py: wrote {a.output} ({time.time() - start:.0f} s)", file=sys.stderr)


if __name__ == "__main__":
    main()
