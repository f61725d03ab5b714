#!/usr/bin/env python3
"""Writes eddies.npy: a wind field for scenes/rain-wind-field.toml, in the
format `[wind.field]` reads (NumPy .npy, float32, shape (nz, ny, nx, 3), the
velocity (x, y, z) in m/s at each grid point, x fastest, y up). Written
without NumPy so that it runs anywhere: python3 make_eddies_npy.py

The field is a row of counter-rotating eddies about vertical axes (a
cellular flow, u = A sin(kx) cos(kz), w = -A cos(kx) sin(kz), divergence
free), 48 m across each, with a gentle updraft in their cores and a
downdraft between them. It is periodic over the grid, so it tiles the
ground without seams: 24 x 8 x 24 points, 4 m apart (96 m x 32 m x 96 m).
"""
import math, struct

NX, NY, NZ, CELL = 24, 8, 24, 4.0
A, UPDRAFT = 6.0, 1.5          # eddy speed, vertical speed, m/s
k = 2.0 * math.pi / (NX * CELL)

values = []
for z in range(NZ):
    for y in range(NY):
        for x in range(NX):
            px, pz = x * CELL, z * CELL
            u = A * math.sin(k * px) * math.cos(k * pz)
            w = -A * math.cos(k * px) * math.sin(k * pz)
            v = UPDRAFT * math.cos(k * px) * math.cos(k * pz) * math.sin(math.pi * y / (NY - 1)) ** 2
            values += [u, v, w]

header = "{'descr': '<f4', 'fortran_order': False, 'shape': (%d, %d, %d, 3), }" % (NZ, NY, NX)
# Magic, version, length, header and newline padded to a multiple of 64 bytes.
header += " " * (-(10 + len(header) + 1) % 64) + "\n"
with open("eddies.npy", "wb") as f:
    f.write(b"\x93NUMPY\x01\x00" + struct.pack("<H", len(header)) + header.encode("latin1"))
    f.write(struct.pack("<%df" % len(values), *values))
