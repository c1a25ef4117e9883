"""Shared pieces of the Python tests: where things are, and small scenes."""

import os
import pathlib
import subprocess

import numpy as np
import pytest

import twinray

REPO = pathlib.Path(__file__).resolve().parents[2]
SCENES = REPO / "examples" / "scenes"


def opencl_ok() -> bool:
    return twinray.opencl_available()[0]


needs_opencl = pytest.mark.skipif(not opencl_ok(), reason="no OpenCL device here")

PRECISIONS = ["float", "double"]


def small_camera(width=96, height=72):
    """The camera of the small scenes built in code (and of their JSON twins)."""
    return twinray.Camera(position=(0, -1.5, 5), look_at=(0, 0, -1), up=(0, -1, 0),
                          viewplane_height=3.0, width=width, height=height)


def assert_code_equals_file(scene, path, precision):
    """`scene`, built in code, renders the same bits as the scene file `path` (CPU, 2 spp),
    and the image is not black."""
    from_code = twinray.Tracer(scene, backend="cpu", precision=precision).render(spp=2)
    from_file = twinray.Tracer(twinray.Scene.load(path), backend="cpu",
                               precision=precision).render(spp=2)
    assert np.array_equal(from_code, from_file)
    assert from_code.max() > 0


def assert_backends_render_alike(scene, precision):
    """The CPU and OpenCL tracers render `scene` with the same bits (2 spp)."""
    cpu = twinray.Tracer(scene, backend="cpu", precision=precision).render(spp=2)
    ocl = twinray.Tracer(scene, backend="opencl", precision=precision).render(spp=2)
    assert np.array_equal(cpu, ocl)


def cli() -> str:
    """The twinray command CTest passes in (TWINRAY_CLI), or the default build's."""
    path = os.environ.get("TWINRAY_CLI", str(REPO / "build" / "apps" / "twinray" / "twinray"))
    if not os.path.exists(path):
        pytest.skip(f"no twinray command at {path} (set TWINRAY_CLI)")
    return path


def run_cli(*args: str) -> None:
    subprocess.run([cli(), *args], check=True, capture_output=True)


def read_pfm(path) -> np.ndarray:
    """A PFM file's values as (height, width, 3) float32, row 0 at the top."""
    data = pathlib.Path(path).read_bytes()
    parts = data.split(b"\n", 3)
    assert parts[0] == b"PF"
    width, height = map(int, parts[1].split())
    assert float(parts[2]) < 0  # little-endian
    values = np.frombuffer(parts[3], dtype="<f4").reshape(height, width, 3)
    return np.ascontiguousarray(values[::-1])


def torus(n_major: int = 48, n_minor: int = 24, R: float = 1.0, r: float = 0.35):
    """A closed torus mesh: vertices (n, 3) float64 and triangles (m, 3) int32."""
    i, j = np.meshgrid(np.arange(n_major), np.arange(n_minor), indexing="ij")
    a = 2 * np.pi * i / n_major
    b = 2 * np.pi * j / n_minor
    v = np.stack([(R + r * np.cos(b)) * np.cos(a), r * np.sin(b), (R + r * np.cos(b)) * np.sin(a)],
                 axis=-1).reshape(-1, 3)
    i2, j2 = (i + 1) % n_major, (j + 1) % n_minor
    q00, q10 = i * n_minor + j, i2 * n_minor + j
    q01, q11 = i * n_minor + j2, i2 * n_minor + j2
    t = np.concatenate([np.stack([q00, q10, q11], -1).reshape(-1, 3),
                        np.stack([q00, q11, q01], -1).reshape(-1, 3)]).astype(np.int32)
    return v, t


def random_rays(n: int, seed: int = 7, box=((-2, -1, -2), (2, 1, 2))):
    """n rays from random points in a box, in uniformly random directions (float64)."""
    rng = np.random.default_rng(seed)
    lo, hi = np.array(box[0], float), np.array(box[1], float)
    o = lo + (hi - lo) * rng.random((n, 3))
    d = rng.normal(size=(n, 3))
    return o, d / np.linalg.norm(d, axis=1, keepdims=True)
