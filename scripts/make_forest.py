#!/usr/bin/env python3
"""Writes a forest scene: one tree asset placed many times by instances.

    python3 scripts/make_forest.py OUT_DIR [--instances 10000] [--triangles 1000000]

OUT_DIR gets forest.json and crown.obj: the tree is an asset of a trunk (an inline
mesh) and a crown (crown.obj, a bumpy closed blob of about --triangles triangles),
placed --instances times on a square grid with random turns, sizes and a few autumn
crowns (an instance's material replaces its asset's). With the defaults the scene
places 1e10 triangles while packing 1e6 once. Render it with

    twinray render OUT_DIR/forest.json -o forest.png

Placement is a fixed pseudo-random sequence (seed 7), so the file is the same on every
run.
"""
import argparse
import json
import math
import os
import random


def write_crown(path, n_triangles):
    """A closed blob: a UV sphere of rows x 2 rows quads, radius displaced by sines."""
    rows = max(2, int(round(math.sqrt(n_triangles / 4.0))))
    cols = 2 * rows
    lines = []
    for j in range(rows + 1):
        theta = math.pi * j / rows
        for i in range(cols):
            phi = 2 * math.pi * i / cols
            r = 1.0 + 0.15 * math.sin(7 * theta) * math.sin(6 * phi) + \
                0.04 * math.sin(41 * theta) * math.sin(37 * phi)
            x = r * math.sin(theta) * math.cos(phi)
            y = 1.3 * r * math.cos(theta)
            z = r * math.sin(theta) * math.sin(phi)
            lines.append("v %.6f %.6f %.6f\n" % (x, y + 2.2, z))
    for j in range(rows):
        for i in range(cols):
            a = j * cols + i + 1
            b = j * cols + (i + 1) % cols + 1
            c, d = a + cols, b + cols
            lines.append("f %d %d %d\nf %d %d %d\n" % (a, c, b, b, c, d))
    with open(path, "w") as f:
        f.writelines(lines)
    return 4 * rows * rows


def trunk_mesh(segments=12):
    """A closed cylinder of radius 0.18 from y = 0 to y = 1.4."""
    vertices, triangles = [], []
    for k in range(segments):
        a = 2 * math.pi * k / segments
        x, z = 0.18 * math.cos(a), 0.18 * math.sin(a)
        vertices += [[round(x, 6), 0.0, round(z, 6)], [round(x, 6), 1.4, round(z, 6)]]
    bottom, top = len(vertices), len(vertices) + 1
    vertices += [[0.0, 0.0, 0.0], [0.0, 1.4, 0.0]]
    for k in range(segments):
        a, b = 2 * k, 2 * ((k + 1) % segments)
        triangles += [[a, a + 1, b], [b, a + 1, b + 1], [bottom, a, b], [top, b + 1, a + 1]]
    return vertices, triangles


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("out_dir")
    p.add_argument("--instances", type=int, default=10000)
    p.add_argument("--triangles", type=float, default=1e6)
    a = p.parse_args()
    if a.instances < 1 or a.triangles < 16:
        p.error("--instances must be >= 1 and --triangles >= 16")
    os.makedirs(a.out_dir, exist_ok=True)
    crown = write_crown(os.path.join(a.out_dir, "crown.obj"), a.triangles)
    vertices, triangles = trunk_mesh()
    side = int(math.ceil(math.sqrt(a.instances)))
    spacing = 3.0
    rng = random.Random(7)
    objects = []
    for k in range(a.instances):
        x = (k % side - (side - 1) / 2.0) * spacing + rng.uniform(-0.8, 0.8)
        z = -(k // side) * spacing + rng.uniform(-0.8, 0.8)
        s = rng.uniform(0.7, 1.3)
        inst = {"type": "instance", "asset": "tree",
                "transform": {"scale": [s, s * rng.uniform(0.85, 1.2), s],
                              "rotate": {"axis": [0, 1, 0], "degrees": round(rng.uniform(0, 360), 3)},
                              "translate": [round(x, 4), 0, round(z, 4)]}}
        if rng.random() < 0.08:
            inst["material"] = "autumn"
        objects.append(inst)
    objects.append({"type": "plane", "point": [0, 0, 0], "normal": [0, 1, 0], "material": "ground"})
    depth = side * spacing
    scene = {
        "twinray": 1,
        "image": {"width": 960, "height": 540, "background": [0.55, 0.7, 0.9]},
        "camera": {"projection": "perspective", "position": [0, 9, 12],
                   "look_at": [0, 0, -min(depth, 60) / 2.0], "up": [0, 1, 0],
                   "viewplane_height": 4.0, "focal_length": 6.0},
        "render": {"spp": 1, "max_depth": 2},
        "materials": {
            "bark": {"color": [0.35, 0.22, 0.12], "ka": 0.2, "kd": 0.8, "ks": 0.05, "shininess": 10},
            "leaves": {"color": [0.15, 0.5, 0.15], "ka": 0.25, "kd": 0.8, "ks": 0.15, "shininess": 20},
            "autumn": {"color": [0.85, 0.4, 0.1], "ka": 0.25, "kd": 0.8, "ks": 0.15, "shininess": 20},
            "ground": {"color": [0.45, 0.4, 0.3], "ka": 0.25, "kd": 0.8, "ks": 0.0, "shininess": 1},
        },
        "lights": [{"type": "point", "position": [-40, 60, 30], "intensity": 9000,
                    "color": [1, 0.97, 0.9]}],
        "assets": {"tree": [
            {"type": "mesh", "vertices": vertices, "triangles": triangles, "material": "bark"},
            {"type": "mesh", "obj": "crown.obj", "material": "leaves"}]},
        "objects": objects,
    }
    with open(os.path.join(a.out_dir, "forest.json"), "w") as f:
        json.dump(scene, f, separators=(",", ":"))
        f.write("\n")
    print("%s: %d instances of a %d-triangle tree (%.3g triangles placed)"
          % (os.path.join(a.out_dir, "forest.json"), a.instances, crown + len(triangles),
             float(a.instances) * (crown + len(triangles))))


if __name__ == "__main__":
    main()
