#!/usr/bin/env python3
"""Prints the realism suite's tables for docs/REALISM.md from the records
that tools/reference/suite.sh wrote (scenes/realism/references/*.json):
the errors without air (the comparison of the cloud models), the
references (samples, truncation, seconds, noise) and the with-air column."""

import glob
import json
import os

root = os.path.join(os.path.dirname(__file__), "..", "..")
records = []
for path in sorted(glob.glob(os.path.join(root, "scenes/realism/references/*.json"))):
    records.append((os.path.basename(path)[:-5], json.load(open(path))))


def pm(value, se, digits=3):
    return f"{value:.{digits}f} ± {se:.{digits}f}"


print("| scene | cloud pixels | block error (4×4) | pixel error | naive pixel RMSE | mean luminance ratio "
      "| red/blue ratio (nimbus / reference) | reference red/blue | HDR-FLIP |")
print("|---|---|---|---|---|---|---|---|---|")
for name, r in records:
    e, h = r["error"], r["error"]["halves"]
    b, p = h["blocks"], h["pixels"]
    print(
        f"| {name} | {p['count']} "
        f"| {pm(b['luminance_relative_rmse_unbiased'], b['luminance_relative_rmse_unbiased_se'])} "
        f"| {pm(p['luminance_relative_rmse_unbiased'], p['luminance_relative_rmse_unbiased_se'])} "
        f"| {p['luminance_relative_rmse_naive']:.3f} "
        f"| {pm(h['mean_luminance_ratio'], h['mean_luminance_ratio_se'])} "
        f"| {pm(h['red_over_blue_ratio'], h['red_over_blue_ratio_se'])} "
        f"| {pm(h['red_over_blue_reference'], h['red_over_blue_reference_se'])} "
        f"| {e['hdr_flip_mean']:.3f} |"
    )
print()
print("| scene | spp | δ-M truncation | f | seconds (2 cores) | reference noise 4×4 / pixel | bound (¼ block error or 0.02) met | largest pixel / 5×5 median |")
print("|---|---|---|---|---|---|---|---|")
for name, r in records:
    ref, h = r["reference"], r["error"]["halves"]
    b, p = h["blocks"], h["pixels"]
    truncation = f"{ref['phase_truncation_deg']:g}°" if ref["phase_truncation_deg"] > 0 else "none (full)"
    if "composite" in ref:
        c = ref["composite"]
        where = (f"within {c['sun_angle_deg']:g}° of the sun" if c["sun_angle_deg"] is not None
                 else f"on the cloud's rim ({c['body_rim_px']} px)")
        truncation = (f"full {where}, 5° elsewhere ({ref['composite_truncated_spp']} spp; "
                      f"{c['check']['truncated_over_full']:.3f} ± "
                      f"{c['check']['truncated_over_full'] * ((c['check']['full']['standard_error'] / c['check']['full']['mean_luminance']) ** 2 + (c['check']['truncated']['standard_error'] / c['check']['truncated']['mean_luminance']) ** 2) ** 0.5:.3f} of the full render there)")
    print(
        f"| {name} | {ref['spp']} | {truncation} | {ref['phase_truncation_fraction']:.3f} | {ref['seconds']:.0f} "
        f"| {b['reference_noise_relative_rmse']:.3f} / {p['reference_noise_relative_rmse']:.3f} "
        f"| {'yes' if ref['noise_bound_met'] else 'NO'} | {ref.get('peak_over_local_median', float('nan')):.2f} |"
    )
print()
print("| scene | block error without / with air | mean luminance ratio without / with air | red/blue ratio without / with air |")
print("|---|---|---|---|")
for name, r in records:
    h, a = r["error"]["halves"], r["error_with_air"]["halves"]
    print(
        f"| {name} | {h['blocks']['luminance_relative_rmse_unbiased']:.3f} / {a['blocks']['luminance_relative_rmse_unbiased']:.3f} "
        f"| {h['mean_luminance_ratio']:.3f} / {a['mean_luminance_ratio']:.3f} "
        f"| {h['red_over_blue_ratio']:.3f} / {a['red_over_blue_ratio']:.3f} |"
    )
