"""The CPU and OpenCL backends give equal arrays, bit for bit: renders, every AOV, ray
queries, in float and double."""

import numpy as np
import pytest

import twinray
from conftest import PRECISIONS, SCENES, needs_opencl, random_rays, torus

pytestmark = needs_opencl
AOVS = ["shaded", "depth", "normal", "shading_normal", "uv", "object"]


def both(scene, precision):
    return (twinray.Tracer(scene, backend="cpu", precision=precision),
            twinray.Tracer(scene, backend="opencl", precision=precision))


@pytest.mark.parametrize("precision", PRECISIONS)
@pytest.mark.parametrize("name", ["demo.json", "placed.json", "models.json", "glass.json"])
def test_render_and_every_aov_equal(name, precision):
    scene = twinray.Scene.load(SCENES / name)
    scene.camera.width, scene.camera.height = 160, 120
    cpu, ocl = both(scene, precision)
    assert (cpu.backend, ocl.backend) == ("cpu", "opencl")
    for aov in AOVS:
        a, b = cpu.render(aov=aov, spp=2), ocl.render(aov=aov, spp=2)
        assert a.dtype == b.dtype
        assert np.array_equal(a, b, equal_nan=True), f"{name} {precision} {aov}"
    # Something was rendered: not all background, and the object AOV names objects.
    assert np.unique(cpu.render(aov="object")).size > 2


@pytest.mark.parametrize("precision", PRECISIONS)
def test_queries_equal(precision):
    scene = twinray.Scene()
    v, t = torus()
    scene.add_mesh(v, t)
    scene.add_sphere((0, 0, 0), 0.3)
    scene.add_plane((0, -0.8, 0), (0, 1, 0))
    cpu, ocl = both(scene, precision)
    o, d = random_rays(20000)
    h1, h2 = cpu.intersect(o, d), ocl.intersect(o, d)
    for field in ("t", "u", "v", "normal", "object", "primitive"):
        assert np.array_equal(getattr(h1, field), getattr(h2, field)), field
    assert 0 < np.count_nonzero(h1.object == 0) < len(h1)  # the torus is hit, and missed
    assert np.array_equal(cpu.occluded(o, d), ocl.occluded(o, d))
    # Occlusion is exactly "intersect found a hit", with a tmax that cuts some hits off.
    blocked = cpu.occluded(o, d, tmax=1.0)
    assert np.array_equal(blocked, cpu.intersect(o, d, tmax=1.0).object >= 0)
    assert np.array_equal(blocked, ocl.occluded(o, d, tmax=1.0))
