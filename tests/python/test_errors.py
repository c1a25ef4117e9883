"""Bad input raises ValueError with the library's message; nothing crashes. A missing
OpenCL platform is a RuntimeError when OpenCL is asked for, and the CPU under "auto"."""

import json
import os
import subprocess
import sys

import numpy as np
import pytest

import twinray
from conftest import REPO, torus


def scene_with_mesh():
    scene = twinray.Scene()
    v, t = torus(8, 6)
    scene.add_mesh(v, t)
    return scene


@pytest.mark.parametrize(
    "vertices, triangles, message",
    [
        (np.zeros((4, 2)), [[0, 1, 2]], r"vertices: must be an \(n, 3\) array, got shape \(4, 2\)"),
        (np.zeros(12), [[0, 1, 2]], r"vertices: must be an \(n, 3\) array"),
        (np.array([["a", "b", "c"]] * 3), [[0, 1, 2]], "vertices: must hold real numbers"),
        (np.eye(3), [[0.0, 1.0, 2.0]], "triangles: must hold integer indices, got dtype float64"),
        (np.eye(3), [[0, 1, 3]], r"objects\[0\].triangles\[0\]\[2\]: vertex index 3 out of range"),
        (np.eye(3), [[0, -1, 2]], r"objects\[0\].triangles\[0\]\[1\]: vertex index -1"),
        (np.array([[0, 0, 0], [1, 0, np.nan], [0, 1, 0]]), [[0, 1, 2]],
         r"objects\[0\].vertices\[1\]: must be finite, got \[1, 0, nan\]"),
        (np.array([[0, 0, 0], [1, 0, np.inf], [0, 1, 0]]), [[0, 1, 2]], r"vertices\[1\]"),
        (np.eye(3), np.zeros((0, 3), np.int32), "triangles: must hold at least one"),
    ],
)
def test_bad_meshes(vertices, triangles, message):
    scene = twinray.Scene()
    with pytest.raises(ValueError, match=message):
        scene.add_mesh(vertices, triangles)
    assert scene.object_count == 0  # nothing half-added


def test_bad_objects_and_materials():
    scene = twinray.Scene()
    with pytest.raises(ValueError, match=r"objects\[0\].radius: must be > 0, got -1"):
        scene.add_sphere((0, 0, 0), -1)
    with pytest.raises(ValueError, match=r"objects\[0\].material: no material with index 7"):
        scene.add_sphere((0, 0, 0), 1, material=7)
    with pytest.raises(ValueError, match=r"materials\[0\].color\[1\]: must be in \[0, 1\]"):
        scene.add_material(color=(0.5, 1.5, 0.5))
    with pytest.raises(ValueError, match=r"objects\[0\].normal: must be non-zero"):
        scene.add_plane((0, 0, 0), (0, 0, 0))
    with pytest.raises(ValueError, match="center: must be 3 numbers"):
        scene.add_sphere((0, 0), 1)
    with pytest.raises(ValueError, match="material: must be an integer index"):
        scene.add_sphere((0, 0, 0), 1, material="red")
    with pytest.raises(ValueError, match=r"transform: must be a 4x4 matrix"):
        scene.add_sphere((0, 0, 0), 1, transform=np.eye(3))
    with pytest.raises(ValueError, match="transform: the last row must be"):
        scene.add_sphere((0, 0, 0), 1, transform=np.ones((4, 4)))
    squash = np.diag([1.0, 2.0, 1.0, 1.0])
    with pytest.raises(ValueError, match=r"objects\[0\].transform: .*sphere"):
        scene.add_sphere((0, 0, 0), 1, transform=squash)
    with pytest.raises(ValueError, match="mask: must be an integer in"):
        scene.add_sphere((0, 0, 0), 1, mask=-1)
    with pytest.raises(ValueError, match=r"no\.obj"):
        scene.add_obj("/nonexistent/no.obj")
    with pytest.raises(ValueError, match=r"background\[0\]: must be in \[0, 1\]"):
        scene.background = (2, 0, 0)
    assert scene.object_count == 0


def test_bad_scene_files(tmp_path):
    with pytest.raises(ValueError, match="missing.json"):
        twinray.Scene.load(tmp_path / "missing.json")
    bad = tmp_path / "bad.json"
    image = {"width": 8, "height": 8}
    camera = {"projection": "perspective", "position": [0, 0, 5], "look_at": [0, 0, 0],
              "up": [0, 1, 0], "viewplane_height": 2}
    bad.write_text(json.dumps({"twinray": 1, "image": image, "camera": camera, "objects": [
        {"type": "sphere", "center": [0, 0, 0], "radius": "big"}]}))
    with pytest.raises(ValueError, match=r"bad.json.*objects\[0\].radius"):
        twinray.Scene.load(bad)
    bad.write_text("{ not json")
    with pytest.raises(ValueError, match="bad.json"):
        twinray.Scene.load(bad)
    bad.write_text(json.dumps({"twinray": 1, "image": image, "camera": camera, "objects": [{"type": "cone"}]}))
    with pytest.raises(ValueError, match=r"objects\[0\].type"):
        twinray.Scene.load(bad)


def test_bad_tracer_arguments():
    scene = scene_with_mesh()
    with pytest.raises(ValueError, match='backend: must be "cpu", "opencl" or "auto"'):
        twinray.Tracer(scene, backend="cuda")
    with pytest.raises(ValueError, match='precision: must be "float" or "double"'):
        twinray.Tracer(scene, precision="half")
    tracer = twinray.Tracer(scene, backend="cpu")
    with pytest.raises(ValueError, match="aov: must be one of"):
        tracer.render(aov="albedo")
    with pytest.raises(ValueError, match="sampler: must be"):
        tracer.render(sampler="sobol")
    with pytest.raises(ValueError, match=r"spp: must be in \[1, "):
        tracer.render(spp=0)
    scene.camera.width = 0
    with pytest.raises(ValueError, match=r"camera.width|width"):
        tracer.render()
    scene.camera.width = 64
    scene.camera.up = scene.camera.look_at  # up along the view direction or not: a message
    scene.camera.up = (0, 0, 0)
    with pytest.raises(ValueError, match="camera.up"):
        tracer.render()
    scene.camera = twinray.Camera()
    scene.lights = [twinray.Light((0, 0, 0), intensity=-2)]
    with pytest.raises(ValueError, match=r"lights\[0\].intensity"):
        tracer.render()
    o = np.zeros((5, 3))
    with pytest.raises(ValueError, match=r"origins: must be an \(n, 3\) array"):
        tracer.intersect(np.zeros((5, 4)), o)
    with pytest.raises(ValueError, match=r"directions: shape \(4, 3\) differs"):
        tracer.intersect(o, np.zeros((4, 3)))
    with pytest.raises(ValueError, match=r"tmax: must be one number or an array of shape \(5,\)"):
        tracer.intersect(o, o, tmax=np.ones(3))
    with pytest.raises(ValueError, match="origins: must hold real numbers"):
        tracer.intersect(o.astype(complex), o)
    with pytest.raises(ValueError, match="mask: must hold integers"):
        tracer.occluded(o, o, mask=np.ones(5))
    with pytest.raises(ValueError, match=r"mask: values must be in"):
        tracer.occluded(o, o, mask=np.full(5, -1))
    with pytest.raises(ValueError, match="image: must be"):
        twinray.write_png("/tmp/never.png", np.zeros((4, 4, 4)))


def test_a_scene_that_overflows_float_is_refused_when_packed():
    scene = twinray.Scene()
    scene.add_sphere((1e39, 0, 0), 1)  # fine in double, infinite in float
    twinray.Tracer(scene, backend="cpu", precision="double")
    with pytest.raises(ValueError, match=r"objects\[0\].center: must be finite"):
        twinray.Tracer(scene, backend="cpu", precision="float")


def test_no_opencl_platform():
    """With no OpenCL platform (no ICD files), the module still loads and works on the CPU;
    backend="opencl" says why it cannot."""
    code = (
        "import numpy as np, twinray\n"
        "s = twinray.Scene(); s.add_sphere((0, 0, -3), 1)\n"
        "print(twinray.opencl_available()[0])\n"
        "print(twinray.Tracer(s, backend='auto').backend)\n"
        "try:\n"
        "    twinray.Tracer(s, backend='opencl')\n"
        "except RuntimeError as e:\n"
        "    print('RuntimeError', e)\n"
    )
    env = dict(os.environ, OCL_ICD_VENDORS="/nonexistent", OPENCL_VENDOR_PATH="/nonexistent")
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True,
                         check=True).stdout.splitlines()
    assert out[0] == "False"
    assert out[1] == "cpu"
    assert out[2].startswith("RuntimeError") and "OpenCL" in out[2]
