"""Area lights and the environment from Python: read from scene files, built in code as
the same scene the file describes (the same bits), rendered alike on both backends, and
bad values refused with the library's message."""

import json

import numpy as np
import pytest

import twinray
from conftest import (PRECISIONS, SCENES, assert_backends_render_alike,
                      assert_code_equals_file, needs_opencl, small_camera)
SKY = SCENES / "sky.hdr"


def scene_in_code():
    scene = twinray.Scene()
    m = scene.add_material(color=(0.8, 0.7, 0.6))
    scene.add_sphere((0, 0, -1), 0.8, material=m)
    scene.add_plane((0, 1, 0), (0, -1, 0), material=m)
    scene.add_rect_light((-2.5, -2, 0.5), (1, 0, 0), (0, 0, 1), intensity=9, samples=3)
    scene.add_sphere_light((3, -2, 2), 0.4, intensity=5, color=(1, 0.9, 0.7), samples=2)
    scene.set_environment(SKY, rotate_degrees=30, intensity=0.8, up=(0, -1, 0))
    scene.camera = small_camera()
    return scene


def scene_as_json(tmp_path):
    text = {
        "twinray": 1,
        "image": {"width": 96, "height": 72,
                  "environment": {"file": str(SKY), "rotate_degrees": 30, "intensity": 0.8,
                                  "up": [0, -1, 0]}},
        "camera": {"projection": "perspective", "position": [0, -1.5, 5], "look_at": [0, 0, -1],
                   "up": [0, -1, 0], "viewplane_height": 3.0},
        "materials": {"m": {"color": [0.8, 0.7, 0.6]}},
        "lights": [
            {"type": "rect", "corner": [-2.5, -2, 0.5], "edge1": [1, 0, 0], "edge2": [0, 0, 1],
             "intensity": 9, "samples": 3},
            {"type": "sphere", "center": [3, -2, 2], "radius": 0.4, "intensity": 5,
             "color": [1, 0.9, 0.7], "samples": 2},
        ],
        "objects": [
            {"type": "sphere", "center": [0, 0, -1], "radius": 0.8, "material": "m"},
            {"type": "plane", "point": [0, 1, 0], "normal": [0, -1, 0], "material": "m"},
        ],
    }
    path = tmp_path / "area.json"
    path.write_text(json.dumps(text))
    return path


def test_scene_files_bring_their_area_lights_and_environment():
    scene = twinray.Scene.load(SCENES / "glass.json")
    assert [l.shape for l in scene.lights] == ["rect"]
    assert scene.lights[0].samples == 4
    assert scene.lights[0].edge1 == (1.2, 0.0, 0.0)
    assert scene.environment_file.endswith("sky.hdr")
    assert twinray.Scene().environment_file is None


@pytest.mark.parametrize("precision", PRECISIONS)
def test_code_built_scene_equals_its_file(tmp_path, precision):
    assert_code_equals_file(scene_in_code(), scene_as_json(tmp_path), precision)


@needs_opencl
@pytest.mark.parametrize("precision", PRECISIONS)
def test_cpu_and_opencl_equal(precision):
    scene = scene_in_code()
    assert_backends_render_alike(scene, precision)


def test_the_environment_is_seen_and_can_be_removed():
    scene = twinray.Scene()
    scene.camera = small_camera(32, 24)
    scene.background = (0.25, 0.5, 0.75)
    tracer = twinray.Tracer(scene, backend="cpu")
    plain = tracer.render()
    assert np.all(plain == np.array([0.25, 0.5, 0.75], dtype=plain.dtype))
    scene.set_environment(SKY, up=(0, -1, 0))
    sky = tracer.render()
    assert np.unique(sky.reshape(-1, 3), axis=0).shape[0] > 10  # a picture, not one color
    scene.set_environment(SKY, up=(0, -1, 0), intensity=2)
    assert np.array_equal(tracer.render(), 2 * sky)
    scene.set_environment(None)
    assert np.array_equal(tracer.render(), plain)


def test_area_lights_soften_shadows():
    # The floor along a row through a sphere's shadow, as the share of the light each
    # pixel gets (over the same render without the sphere): a point light leaves all or
    # nothing, a rect light of the same intensity a band of shares between them.
    def row(light, blocked):
        scene = twinray.Scene()
        m = scene.add_material(color=(1, 1, 1), ka=0.0, ks=0.0)
        if blocked:
            scene.add_sphere((0, -1, 0), 0.5, material=m)
        scene.add_plane((0, 0, 0), (0, -1, 0), material=m)
        light(scene)
        scene.camera = twinray.Camera(position=(0, -0.1, 0), look_at=(0, 0, 0), up=(0, 0, -1),
                                      projection="orthographic", viewplane_height=0.06,
                                      width=200, height=3)
        return twinray.Tracer(scene, backend="cpu").render()[1, :, 0]

    def between(light):
        share = row(light, True) / row(light, False)
        return np.count_nonzero((share > 0.05) & (share < 0.95))

    assert between(lambda s: s.add_light((0, -4, 0), intensity=16)) <= 2
    assert between(lambda s: s.add_rect_light((-1, -4, -1), (2, 0, 0), (0, 0, 2),
                                              intensity=16, samples=8)) > 20


def test_bad_lights_and_environments_are_refused():
    scene = twinray.Scene()
    scene.add_sphere((0, 0, -1), 0.5)
    scene.camera = small_camera(8, 6)
    scene.lights.append(twinray.Light(shape="disk"))
    tracer = twinray.Tracer(scene, backend="cpu")
    with pytest.raises(ValueError, match=r'lights\[0\]\.shape: must be "point", "rect" or '):
        tracer.render()
    scene.lights = []
    scene.add_rect_light((0, 0, 0), (1, 0, 0), (0, 0, 1), samples=0)
    with pytest.raises(ValueError, match=r"lights\[0\]\.samples: must be in \[1, 64\], got 0"):
        tracer.render()
    scene.lights = []
    scene.add_sphere_light((0, 0, 0), -1.0)
    with pytest.raises(ValueError, match=r"lights\[0\]\.radius: must be > 0, got -1"):
        tracer.render()
    with pytest.raises(ValueError, match="samples: must be an integer, got 2.5"):
        scene.add_rect_light((0, 0, 0), (1, 0, 0), (0, 0, 1), samples=2.5)
    with pytest.raises(ValueError, match="nonexistent.hdr"):
        scene.set_environment("/nonexistent.hdr")
    with pytest.raises(ValueError, match=r"image\.environment\.up: must be a non-zero vector"):
        scene.set_environment(SKY, up=(0, 0, 0))
    with pytest.raises(ValueError, match=r"image\.environment\.intensity: must be >= 0"):
        scene.set_environment(SKY, intensity=-1)
    assert scene.environment_file is None  # nothing of a refused one stays
