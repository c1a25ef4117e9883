"""Assets and instances from Python: a scene built in code equals the same scene written
as JSON (the same bits), CPU and OpenCL agree, ray queries report the instance, and bad
uses are refused with the library's message."""

import json

import numpy as np
import pytest

import twinray
from conftest import (PRECISIONS, SCENES, assert_backends_render_alike,
                      assert_code_equals_file, needs_opencl, small_camera)

# Row by row, as the scene format's "matrix" writes it: scale 0.5, mirror in x, move.
PLACE = [[-0.5, 0, 0, 2.0], [0, 0.5, 0, -0.25], [0, 0, 0.5, -1.0], [0, 0, 0, 1]]


def scene_in_code():
    scene = twinray.Scene()
    red = scene.add_material(color=(0.9, 0.2, 0.1))
    blue = scene.add_material(color=(0.1, 0.3, 0.9))
    pair = scene.add_asset("pair")
    assert scene.add_sphere((0.6, 0, 0), 0.4, material=red, asset=pair) == 0
    assert scene.add_triangle((-1, 0, 0), (0, 0, 0), (-0.5, -1, 0), material=blue,
                              asset=pair) == 1
    assert scene.add_instance(pair) == 0
    assert scene.add_instance(pair, transform=PLACE, material=blue) == 1
    scene.add_plane((0, 1, 0), (0, -1, 0), material=red)
    scene.add_light((-2, -3, 2), intensity=10)
    scene.camera = small_camera()
    return scene


def scene_as_json(tmp_path):
    text = {
        "twinray": 1,
        "image": {"width": 96, "height": 72},
        "camera": {"projection": "perspective", "position": [0, -1.5, 5], "look_at": [0, 0, -1],
                   "up": [0, -1, 0], "viewplane_height": 3.0},
        "materials": {"red": {"color": [0.9, 0.2, 0.1]}, "blue": {"color": [0.1, 0.3, 0.9]}},
        "lights": [{"type": "point", "position": [-2, -3, 2], "intensity": 10}],
        "assets": {"pair": [
            {"type": "sphere", "center": [0.6, 0, 0], "radius": 0.4, "material": "red"},
            {"type": "triangle", "vertices": [[-1, 0, 0], [0, 0, 0], [-0.5, -1, 0]],
             "material": "blue"}]},
        "objects": [
            {"type": "instance", "asset": "pair"},
            {"type": "instance", "asset": "pair", "material": "blue",
             "transform": {"matrix": PLACE}},
            {"type": "plane", "point": [0, 1, 0], "normal": [0, -1, 0], "material": "red"},
        ],
    }
    path = tmp_path / "instances.json"
    path.write_text(json.dumps(text))
    return path


@pytest.mark.parametrize("precision", PRECISIONS)
def test_code_built_instances_equal_their_file(tmp_path, precision):
    assert_code_equals_file(scene_in_code(), scene_as_json(tmp_path), precision)


@needs_opencl
@pytest.mark.parametrize("precision", PRECISIONS)
def test_cpu_and_opencl_equal(precision):
    scene = scene_in_code()
    assert_backends_render_alike(scene, precision)
    rays_o = np.array([[0.6, 0, 5], [1.7, -0.25, 5], [3, 0, 5]], dtype=np.float64)
    rays_d = np.array([[0, 0, -1]] * 3, dtype=np.float64)
    a = twinray.Tracer(scene, backend="cpu", precision=precision).intersect(rays_o, rays_d)
    b = twinray.Tracer(scene, backend="opencl", precision=precision).intersect(rays_o, rays_d)
    for name in ("t", "u", "v", "normal", "object", "primitive", "instance"):
        assert np.array_equal(getattr(a, name), getattr(b, name)), name


def test_queries_report_the_instance_and_the_object_in_its_asset():
    tracer = twinray.Tracer(scene_in_code(), backend="cpu", precision="double")
    # Down -z onto: the first instance's sphere (center (0.6, 0, 0), r 0.4); the second's
    # sphere, mirrored to x = 2 - 0.3 = 1.7, at z = -1 with r 0.2; and nothing.
    o = np.array([[0.6, 0, 5], [1.7, -0.25, 5], [3, 0, 5]])
    d = np.array([[0, 0, -1]] * 3, dtype=np.float64)
    hits = tracer.intersect(o, d)
    assert list(hits.instance) == [0, 1, -1]
    assert list(hits.object) == [0, 0, -1]
    assert hits.t[0] == pytest.approx(5 - 0.4, abs=1e-12)
    assert hits.t[1] == pytest.approx(5 - (-1 + 0.2), abs=1e-12)
    assert np.allclose(hits.normal[:2], [[0, 0, 1], [0, 0, 1]], atol=1e-12)
    assert list(tracer.occluded(o, d)) == [True, True, False]


def test_bad_assets_and_instances_are_refused():
    scene = twinray.Scene()
    m = scene.add_material()
    a = scene.add_asset("tree")
    with pytest.raises(ValueError, match=r"asset: no asset with index 3 \(1 defined\)"):
        scene.add_sphere((0, 0, 0), 1, material=m, asset=3)
    with pytest.raises(ValueError, match=r"objects\[0\].asset: no asset with index 5"):
        scene.add_instance(5)
    flat = [[1, 0, 0, 0], [0, 0, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]]
    with pytest.raises(ValueError, match=r"transform: the transform is singular"):
        scene.add_instance(a, transform=flat)
    assert scene.object_count == 0
    # An asset with nothing in it is refused when the scene is packed.
    scene.add_instance(a)
    scene.camera = small_camera(8, 6)
    with pytest.raises(ValueError, match=r"assets.tree: holds no objects"):
        twinray.Tracer(scene, backend="cpu").render()


def test_the_example_scene_loads_and_renders_its_instances():
    scene = twinray.Scene.load(SCENES / "instances.json")
    scene.camera.width, scene.camera.height = 64, 40
    ids = twinray.Tracer(scene, backend="cpu").render(aov="object")
    assert set(np.unique(ids).astype(int)) >= {0, 1, 2, 3, 4}


def test_the_forest_script_writes_a_scene_that_renders_alike_on_both_backends(tmp_path):
    import subprocess
    import sys
    from conftest import REPO
    subprocess.run([sys.executable, str(REPO / "scripts" / "make_forest.py"), str(tmp_path),
                    "--instances", "60", "--triangles", "2000"], check=True, capture_output=True)
    scene = twinray.Scene.load(tmp_path / "forest.json")
    assert scene.object_count == 61  # 60 instances and the ground
    scene.camera.width, scene.camera.height = 96, 54
    cpu = twinray.Tracer(scene, backend="cpu").render()
    assert np.count_nonzero(cpu) > cpu.size // 2
    if twinray.opencl_available()[0]:
        assert np.array_equal(cpu, twinray.Tracer(scene, backend="opencl").render())
    ids = twinray.Tracer(scene, backend="cpu").render(aov="object")
    assert len(np.unique(ids)) > 10  # many instances in view, each its own object index
