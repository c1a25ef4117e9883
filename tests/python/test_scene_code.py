"""A scene built in code equals the same scene written as JSON, bit for bit."""

import json

import numpy as np
import pytest

import twinray
from conftest import SCENES, torus

OBJ = SCENES / "textured_torus.obj"
TRANSFORM = {"scale": [0.8, 0.8, 0.8], "rotate": {"axis": [1, 2, 0.5], "degrees": 33},
             "translate": [0.3, -0.1, 0.2]}
# The same map as a matrix, row by row (scale, then rotate, then translate).
ANGLE = np.radians(33.0)


def rotation(axis, radians):
    a = np.asarray(axis, float) / np.linalg.norm(axis)
    k = np.array([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])
    return np.cos(radians) * np.eye(3) + np.sin(radians) * k + (1 - np.cos(radians)) * np.outer(a, a)


def moved():
    """A rotation by a third of a turn about (1, 1, 1), scaled by 1.1 and moved: rounding
    before or after it changes bits."""
    m = np.eye(4)
    m[:3, :3] = rotation([1, 1, 1], np.radians(120.0)) * 1.1
    m[:3, 3] = [0.1, 0.05, -0.3]
    return m


def build_in_code(v, t):
    scene = twinray.Scene()
    clay = scene.add_material(color=(0.85, 0.55, 0.4), ka=0.1, kd=0.8, ks=0.3, shininess=40)
    mirror = scene.add_material(color=(0.9, 0.9, 0.9), ka=0.05, kd=0.3, ks=0.6, shininess=80,
                                glaze=0.5)
    scene.add_plane((0, -0.5, 0), (0, 1, 0), material=mirror)
    scene.add_sphere((1.2, 0.1, -0.4), 0.35, material=clay, transform=moved())
    scene.add_triangle((-1.5, -0.5, -1), (-0.5, -0.5, -1.2), (-1, 0.6, -1.1), material=clay)
    scene.add_mesh(v, t, material=clay)
    scene.add_obj(OBJ, material=mirror, transform=np.eye(4))
    m = np.eye(4)
    m[:3, :3] = rotation([1, 2, 0.5], ANGLE) * 0.8
    m[:3, 3] = [0.3, -0.1, 0.2]
    scene.add_obj(OBJ, transform=m)  # its own MTL material and texture
    glass = scene.add_material(color=(1, 1, 1), ka=0, kd=0, ks=0.9, shininess=300, glaze=0.05,
                               transmission=0.95, ior=1.45, absorption=(0.3, 1.2, 3.0))
    scene.add_sphere((-0.4, 0.2, 1.2), 0.45, material=glass)
    scene.add_light((-3, 5, 4), intensity=30, color=(1, 0.9, 0.8))
    scene.add_light((3, 4, 2), intensity=12)
    scene.camera = twinray.Camera((0, 2.5, 5), (0, 0, 0), (0, 1, 0), viewplane_height=3.2,
                                  width=200, height=150)
    scene.background = (0.02, 0.03, 0.05)
    return scene


def as_json(path, v, t):
    matrix = np.eye(4)
    matrix[:3, :3] = rotation([1, 2, 0.5], ANGLE) * 0.8
    matrix[:3, 3] = [0.3, -0.1, 0.2]
    doc = {
        "twinray": 1,
        "image": {"width": 200, "height": 150, "background": [0.02, 0.03, 0.05]},
        "camera": {"projection": "perspective", "position": [0, 2.5, 5], "look_at": [0, 0, 0],
                   "up": [0, 1, 0], "viewplane_height": 3.2},
        "materials": {
            "clay": {"color": [0.85, 0.55, 0.4], "ka": 0.1, "kd": 0.8, "ks": 0.3,
                     "shininess": 40},
            "mirror": {"color": [0.9, 0.9, 0.9], "ka": 0.05, "kd": 0.3, "ks": 0.6,
                       "shininess": 80, "glaze": 0.5},
            "glass": {"color": [1, 1, 1], "ka": 0, "kd": 0, "ks": 0.9, "shininess": 300,
                      "glaze": 0.05, "transmission": 0.95, "ior": 1.45,
                      "absorption": [0.3, 1.2, 3.0]},
        },
        "lights": [
            {"type": "point", "position": [-3, 5, 4], "intensity": 30, "color": [1, 0.9, 0.8]},
            {"type": "point", "position": [3, 4, 2], "intensity": 12},
        ],
        "objects": [
            {"type": "plane", "point": [0, -0.5, 0], "normal": [0, 1, 0], "material": "mirror"},
            {"type": "sphere", "center": [1.2, 0.1, -0.4], "radius": 0.35, "material": "clay",
             "transform": {"matrix": moved().tolist()}},
            {"type": "triangle", "vertices": [[-1.5, -0.5, -1], [-0.5, -0.5, -1.2],
                                              [-1, 0.6, -1.1]], "material": "clay"},
            {"type": "mesh", "vertices": v.tolist(), "triangles": t.tolist(),
             "material": "clay"},
            {"type": "mesh", "obj": str(OBJ), "material": "mirror",
             "transform": {"matrix": np.eye(4).tolist()}},
            {"type": "mesh", "obj": str(OBJ), "transform": {"matrix": matrix.tolist()}},
            {"type": "sphere", "center": [-0.4, 0.2, 1.2], "radius": 0.45, "material": "glass"},
        ],
    }
    path.write_text(json.dumps(doc))
    return path


@pytest.mark.parametrize("precision", ["float", "double"])
def test_code_equals_json(tmp_path, precision):
    v, t = torus(24, 12, R=0.7, r=0.2)
    v = v + [-0.6, 0.0, 0.5]
    code = build_in_code(v, t)
    loaded = twinray.Scene.load(as_json(tmp_path / "scene.json", v, t))
    assert (code.object_count, code.material_count) == (loaded.object_count, loaded.material_count)
    a = twinray.Tracer(code, backend="cpu", precision=precision)
    b = twinray.Tracer(loaded, backend="cpu", precision=precision)
    for aov in ["shaded", "uv", "object", "shading_normal"]:
        assert np.array_equal(a.render(aov=aov, spp=2), b.render(aov=aov, spp=2)), aov
    image = a.render(spp=2)
    assert image.std() > 0.02
    # Every object is seen.
    assert set(np.unique(a.render(aov="object"))) >= {0, 1, 2, 3, 4, 5, 6}
    rng = np.random.default_rng(3)
    o = rng.uniform(-2, 2, (5000, 3))
    d = rng.normal(size=(5000, 3))
    h1, h2 = a.intersect(o, d), b.intersect(o, d)
    assert np.array_equal(h1.t, h2.t) and np.array_equal(h1.primitive, h2.primitive)
