#!/usr/bin/env python3
"""Prints the realism suite's table for docs/REALISM.md from the records
that tools/reference/suite.sh wrote (scenes/realism/references/*.json)."""

import glob
import json
import os

root = os.path.join(os.path.dirname(__file__), "..", "..")
rows = []
for path in sorted(glob.glob(os.path.join(root, "scenes/realism/references/*.json"))):
    r = json.load(open(path))
    e = r["error"]
    name = os.path.basename(path)[:-5]
    baseline = r.get("baseline_error", e)["hdr_flip_mean"]
    rows.append(
        f"| {name} | {e['pixels']} | {e['hdr_flip_mean']:.3f} | {baseline:.3f} | {r['reference_noise_hdr_flip_mean']:.3f} "
        f"| {e['luminance_relative_rmse']:.2f} | {e['luminance_psnr_db']:.1f} | {e['mean_luminance_ratio']:.2f} "
        f"| {e['red_over_blue_test']:.2f} / {e['red_over_blue_reference']:.2f} "
        f"| {e['mean_chromaticity_difference_xy']:.4f} | {r['spp']} |"
    )
print("| scene | cloud pixels | HDR-FLIP | baseline HDR-FLIP | reference noise (FLIP of halves) "
      "| luminance RMSE / mean | PSNR dB | mean luminance ratio | red/blue nimbus / reference | Δxy | spp |")
print("|---|---|---|---|---|---|---|---|---|---|---|")
print("\n".join(rows))
