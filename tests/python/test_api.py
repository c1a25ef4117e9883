"""What Tracer and Scene promise: misses, masks, per-ray limits, no repacking for camera
and light changes, the GIL released, typed package files."""

import pathlib
import threading
import time

import numpy as np
import pytest

import twinray
from conftest import random_rays, torus


def sphere_scene():
    scene = twinray.Scene()
    m = scene.add_material(color=(0.8, 0.2, 0.2))
    scene.add_sphere((0, 0, -3), 1, material=m, mask=0b01)
    scene.add_sphere((0, 0, -6), 1, material=m, mask=0b10)
    scene.add_light((2, 2, 0), intensity=10)
    scene.camera = twinray.Camera((0, 0, 0), (0, 0, -1), (0, 1, 0), viewplane_height=2,
                                  width=32, height=24)
    return scene


@pytest.mark.parametrize("precision", ["float", "double"])
def test_hits_misses_masks_and_limits(precision):
    tracer = twinray.Tracer(sphere_scene(), backend="cpu", precision=precision)
    dtype = np.float32 if precision == "float" else np.float64
    o = np.zeros((4, 3))
    d = np.array([[0, 0, -1], [0, 1, 0], [0, 0, -2], [0, 0, 0]], float)
    hits = tracer.intersect(o, d)
    assert hits.t.dtype == dtype and hits.normal.shape == (4, 3)
    assert hits.object.dtype == np.int32 and len(hits) == 4
    assert hits.t[0] == 2 and hits.object[0] == 0 and hits.primitive[0] == 0
    assert np.array_equal(hits.normal[0], [0, 0, 1])
    assert hits.t[2] == 1  # t counts lengths of the direction
    for miss in (1, 3):  # nothing there; a zero direction
        assert hits.t[miss] == np.inf and hits.object[miss] == -1 and hits.primitive[miss] == -1
    # The mask skips the first sphere; tmin and tmax per ray.
    assert tracer.intersect(o[:1], d[:1], mask=0b10).object[0] == 1
    assert tracer.intersect(o[:1], d[:1], mask=np.array([0b100])).object[0] == -1
    h = tracer.intersect(np.zeros((3, 3)), np.tile([0, 0, -1.0], (3, 1)), tmin=[0, 2.5, 0],
                         tmax=[np.inf, np.inf, 1.5])
    assert list(h.object) == [0, 0, -1] and h.t[1] == 4  # the far side of the first sphere
    assert list(tracer.occluded(o, d)) == [True, False, True, False]
    assert list(tracer.occluded(o, d, tmax=1.9)) == [False, False, True, False]


def test_inputs_of_any_layout_give_the_same_hits():
    scene = twinray.Scene()
    v, t = torus()
    scene.add_mesh(v, t)
    tracer = twinray.Tracer(scene, backend="cpu")
    o, d = random_rays(3000)
    ref = tracer.intersect(o.astype(np.float32), d.astype(np.float32))
    # float64 and Fortran-ordered arrays are converted once, to the same values.
    for oo, dd in [(o, d), (np.asfortranarray(o), d), (o.tolist(), d.tolist())]:
        h = tracer.intersect(oo, dd)
        assert np.array_equal(h.t, ref.t) and np.array_equal(h.primitive, ref.primitive)
    # A strided view reads the rays it shows.
    both = np.concatenate([o, d], axis=1).astype(np.float32)
    h = tracer.intersect(both[:, :3], both[:, 3:])
    assert np.array_equal(h.t, ref.t)
    # Triangle indices of any integer type.
    s2 = twinray.Scene()
    s2.add_mesh(v.astype(np.float32), t.astype(np.uint16))
    assert np.array_equal(twinray.Tracer(s2, backend="cpu").intersect(o, d).t, ref.t)
    assert tracer.intersect(np.zeros((0, 3)), np.zeros((0, 3))).t.shape == (0,)


def test_camera_and_light_changes_repack_nothing():
    scene = sphere_scene()
    tracer = twinray.Tracer(scene, backend="cpu")
    assert tracer.pack_count == 1
    first = tracer.render()
    scene.camera.position = (0.5, 0, 0)
    scene.lights[0].intensity = 3
    scene.add_light((-2, 0, 0), intensity=4)
    moved = tracer.render()
    assert tracer.pack_count == 1 and not np.array_equal(first, moved)
    # The same image as a tracer made for the changed scene.
    assert np.array_equal(moved, twinray.Tracer(scene, backend="cpu").render())
    scene.add_sphere((0, 1, -3), 0.5)
    tracer.render()
    assert tracer.pack_count == 2  # objects changed: packed again
    tracer.intersect(np.zeros((1, 3)), [[0, 0, -1]])
    assert tracer.pack_count == 2


def test_the_gil_is_released_while_tracing():
    scene = twinray.Scene()
    v, t = torus(200, 100)
    scene.add_mesh(v, t)
    tracer = twinray.Tracer(scene, backend="cpu")
    o, d = random_rays(400_000)
    o, d = o.astype(np.float32), d.astype(np.float32)
    done = threading.Event()
    ticks = 0

    def cast():
        for _ in range(3):
            tracer.intersect(o, d)
        done.set()

    worker = threading.Thread(target=cast)
    start = time.perf_counter()
    worker.start()
    while not done.is_set():
        ticks += 1
        time.sleep(0.001)
    worker.join()
    elapsed = time.perf_counter() - start
    # Held, the GIL would keep this loop at a handful of turns in all; released, it turns
    # about once a millisecond while the rays are traced.
    assert ticks > 0.2 * elapsed * 1000, (ticks, elapsed)


def test_package_ships_types():
    package = pathlib.Path(twinray.__file__).parent
    assert (package / "py.typed").exists()
    stub = (package / "_core.pyi").read_text()
    assert "class TracerFloat" in stub and "def intersect" in stub
    assert twinray.Tracer.intersect.__doc__ and twinray.Scene.add_mesh.__doc__
    assert twinray.__version__.count(".") == 2
