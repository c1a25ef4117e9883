#!/usr/bin/env python3
"""Writes examples/scenes/sky.hdr: a small procedural sky as an equirectangular Radiance
HDR image (flat RGBE scanlines), the environment of examples/scenes/glass.json.

A blue gradient from the horizon to the zenith, a sun of radiance 40 (above 1: an HDR
value) with a glow, a band of green hills and brown ground below. u = 0.5 (the middle
column) is seen along -z, the top row straight up (docs/scene-format.md, "environment").

    python3 scripts/make_sky_hdr.py [OUT]
"""
import math
import struct
import sys

WIDTH, HEIGHT = 256, 128
SUN_U, SUN_ELEVATION, SUN_RADIUS = 0.38, math.radians(32.0), math.radians(3.0)


def lerp(a, b, t):
    return tuple(x + (y - x) * t for x, y in zip(a, b))


def radiance(u, elevation):
    azimuth = (u - 0.5) * 2.0 * math.pi
    hills = 0.06 + 0.035 * math.sin(6.0 * math.pi * u) + 0.02 * math.sin(14.0 * math.pi * u + 1.0)
    if elevation < 0.0:
        t = min(1.0, -elevation / (0.5 * math.pi))
        return lerp((0.30, 0.24, 0.17), (0.08, 0.06, 0.05), t ** 0.5)
    if elevation < hills:
        return (0.10, 0.20, 0.08)
    t = math.sin(elevation) ** 0.6
    sky = lerp((0.80, 0.88, 1.00), (0.12, 0.30, 0.85), t)
    # The angle to the sun, from the dot product of the two directions.
    d = (math.cos(elevation) * math.sin(azimuth), math.sin(elevation),
         -math.cos(elevation) * math.cos(azimuth))
    sa = (SUN_U - 0.5) * 2.0 * math.pi
    s = (math.cos(SUN_ELEVATION) * math.sin(sa), math.sin(SUN_ELEVATION),
         -math.cos(SUN_ELEVATION) * math.cos(sa))
    angle = math.acos(max(-1.0, min(1.0, sum(a * b for a, b in zip(d, s)))))
    if angle < SUN_RADIUS:
        return (40.0, 36.0, 28.0)
    glow = 1.5 * math.exp(-angle / 0.12)
    return tuple(c + glow * k for c, k in zip(sky, (1.0, 0.85, 0.6)))


def texel(x, y, n=4):
    """The mean of n x n samples over texel (x, y): edges come out smooth."""
    total = [0.0, 0.0, 0.0]
    for j in range(n):
        elevation = 0.5 * math.pi - (y + (j + 0.5) / n) / HEIGHT * math.pi
        for i in range(n):
            c = radiance((x + (i + 0.5) / n) / WIDTH, elevation)
            total = [t + v / (n * n) for t, v in zip(total, c)]
    return total


def rgbe(c):
    v = max(c)
    if v < 1e-32:
        return b"\0\0\0\0"
    m, e = math.frexp(v)
    scale = m * 256.0 / v
    return bytes([min(255, int(x * scale)) for x in c] + [e + 128])


def main():
    out = sys.argv[1] if len(sys.argv) > 1 else "examples/scenes/sky.hdr"
    rows = []
    for y in range(HEIGHT):
        rows.append(b"".join(rgbe(texel(x, y)) for x in range(WIDTH)))
    header = b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y %d +X %d\n" % (HEIGHT, WIDTH)
    with open(out, "wb") as f:
        f.write(header + b"".join(rows))


if __name__ == "__main__":
    main()
