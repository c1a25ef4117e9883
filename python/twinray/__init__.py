"""twinray: ray tracing with the same bits on every CPU and OpenCL device.

Build or load a scene, then render it or cast your own rays at it through a Tracer::

    import numpy as np, twinray
    scene = twinray.Scene()
    m = scene.add_material(color=(0.8, 0.8, 0.8))
    scene.add_mesh(vertices, triangles, material=m)
    scene.add_light((0, 5, 5), intensity=40)
    scene.camera = twinray.Camera((0, 0, 5), (0, 0, 0), (0, 1, 0), width=640, height=480)
    tracer = twinray.Tracer(scene, backend="auto")
    image = tracer.render(spp=4)                       # (480, 640, 3) float32
    hits = tracer.intersect(origins, directions)       # hits.t, hits.object, ...

Both backends ("cpu" and "opencl") return equal arrays, bit for bit, in float and in
double (docs/python.md). Bad input raises ValueError with the library's message (it
names the value: ``objects[2].vertices[7]: must be finite, got [nan, 0, 1]``); a device
that fails raises RuntimeError.
"""

from __future__ import annotations

import math
import os
import warnings
from dataclasses import dataclass, field
from typing import Any, List, Optional, Sequence, Tuple, Union

import numpy as np

from . import _core

__version__: str = _core.__version__

__all__ = [
    "Camera",
    "Hits",
    "Light",
    "Scene",
    "Tracer",
    "opencl_available",
    "write_pfm",
    "write_png",
]

Vector = Union[Sequence[float], np.ndarray]
PathLike = Union[str, "os.PathLike[str]"]

_ALL_BITS = 0xFFFFFFFF
_AOVS = ("shaded", "depth", "normal", "shading_normal", "uv", "object")


def _vec3(name: str, value: Any) -> Tuple[float, float, float]:
    """Three real numbers, as a tuple of Python floats."""
    a = _real_array(name, value)
    if a.shape != (3,):
        raise ValueError(f"{name}: must be 3 numbers, got an array of shape {a.shape}")
    return (float(a[0]), float(a[1]), float(a[2]))


def _real_array(name: str, value: Any) -> np.ndarray:
    try:
        a = np.asarray(value)
    except (TypeError, ValueError) as e:
        raise ValueError(f"{name}: not an array of numbers ({e})") from None
    if a.dtype.kind not in "fiu":
        raise ValueError(f"{name}: must hold real numbers, got dtype {a.dtype}")
    return a


def _rows(name: str, value: Any, dtype: Any, columns: int = 3) -> np.ndarray:
    """An (n, columns) C-contiguous array of dtype: read in place when it is one already,
    converted once otherwise."""
    a = _real_array(name, value)
    if a.ndim != 2 or a.shape[1] != columns:
        raise ValueError(f"{name}: must be an (n, {columns}) array, got shape {a.shape}")
    return np.ascontiguousarray(a, dtype=dtype)


def _index(name: str, value: Any, what: str = "an integer index") -> int:
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, np.integer)):
        raise ValueError(f"{name}: must be {what}, got {value!r}")
    return int(value)


def _count(name: str, value: Any) -> int:
    return _index(name, value, "an integer")


def _mask(value: Any) -> int:
    m = _index("mask", value)
    if not 0 <= m <= _ALL_BITS:
        raise ValueError(f"mask: must be an integer in [0, 4294967295], got {m}")
    return m


def _transform(value: Any) -> Optional[Tuple[float, ...]]:
    """A 4x4 affine matrix (row by row, as the scene format writes it), or None."""
    if value is None:
        return None
    a = _real_array("transform", value)
    if a.shape != (4, 4):
        raise ValueError(f"transform: must be a 4x4 matrix, got an array of shape {a.shape}")
    return tuple(float(x) for x in a.astype(np.float64).ravel())


@dataclass
class Camera:
    """A pinhole (or orthographic) camera, set up as in the scene format's ``camera``.

    position, look_at: world units; up: any length, not along the view direction;
    viewplane_height: world units; focal_length: perspective only, default
    |position - look_at|; width, height: pixels.
    """

    position: Vector = (4.0, -1.0, 5.0)
    look_at: Vector = (0.0, 0.0, -1.0)
    up: Vector = (0.0, -1.0, 0.0)
    projection: str = "perspective"
    viewplane_height: float = 6.0
    width: int = 400
    height: int = 400
    focal_length: Optional[float] = None

    def _native(self) -> "_core.Camera":
        c = _core.Camera()
        c.position = _vec3("camera.position", self.position)
        c.look_at = _vec3("camera.look_at", self.look_at)
        c.up = _vec3("camera.up", self.up)
        if self.projection not in ("perspective", "orthographic"):
            raise ValueError(
                f'camera.projection: must be "perspective" or "orthographic", '
                f"got {self.projection!r}"
            )
        c.projection = self.projection
        c.viewplane_height = float(self.viewplane_height)
        c.focal_length = None if self.focal_length is None else float(self.focal_length)
        c.width = _index("camera.width", self.width)
        c.height = _index("camera.height", self.height)
        return c

    @classmethod
    def _from_native(cls, c: "_core.Camera") -> "Camera":
        return cls(tuple(c.position), tuple(c.look_at), tuple(c.up), c.projection,
                   c.viewplane_height, c.width, c.height, c.focal_length)


@dataclass
class Light:
    """A light. shape "point": an isotropic point light at `position`, irradiance
    intensity x color / d^2 at distance d. "rect" (corner `position`, edges `edge1`,
    `edge2`) and "sphere" (center `position`, `radius`): area lights, seen by shading
    as samples x samples point lights of 1/samples^2 of the intensity each, placed
    anew in every path (soft shadows)."""

    position: Vector = (0.0, 0.0, 0.0)
    intensity: float = 1.0
    color: Vector = (1.0, 1.0, 1.0)
    shape: str = "point"
    edge1: Vector = (0.0, 0.0, 0.0)
    edge2: Vector = (0.0, 0.0, 0.0)
    radius: float = 0.0
    samples: int = 1

    def _native(self, i: int) -> "_core.Light":
        light = _core.Light()
        light.position = _vec3(f"lights[{i}].position", self.position)
        light.intensity = float(self.intensity)
        light.color = _vec3(f"lights[{i}].color", self.color)
        light.shape = str(self.shape)
        light.edge1 = _vec3(f"lights[{i}].edge1", self.edge1)
        light.edge2 = _vec3(f"lights[{i}].edge2", self.edge2)
        light.radius = float(self.radius)
        light.samples = _count(f"lights[{i}].samples", self.samples)
        return light


class Scene:
    """Materials, objects, lights, a camera and a background.

    Objects and materials are numbered in the order they are added (after those of a
    loaded file): the number is the object's identity in hits and in the "object" AOV.
    The camera and the lights are plain Python values: change them and render again,
    and nothing is repacked. Adding objects or materials makes the next render pack
    the scene again.
    """

    def __init__(self) -> None:
        self._scene = _core.Scene()
        self.camera: Camera = Camera()
        self.lights: List[Light] = []

    @classmethod
    def load(cls, path: PathLike) -> "Scene":
        """A scene file (docs/scene-format.md); OBJ paths in it are relative to it.
        Its camera, lights and ``render`` options come with it."""
        scene = cls()
        scene._scene.load(os.fspath(path))
        scene.camera = Camera._from_native(scene._scene.file_camera)
        scene.lights = [
            Light(tuple(l.position), l.intensity, tuple(l.color), l.shape, tuple(l.edge1),
                  tuple(l.edge2), l.radius, l.samples) for l in scene._scene.file_lights
        ]
        for w in scene._scene.file_warnings:
            warnings.warn(w, stacklevel=2)
        return scene

    def add_material(self, color: Vector = (0.8, 0.8, 0.8), ka: float = 0.1, kd: float = 0.7,
                     ks: float = 0.5, shininess: float = 65.0, glaze: float = 0.0,
                     transmission: float = 0.0, ior: float = 1.5,
                     absorption: Vector = (0.0, 0.0, 0.0)) -> int:
        """A Blinn-Phong material (linear RGB color in [0, 1]; glaze: mirror reflectivity
        in [0, 1]), or glass: transmission in [0, 1 - glaze] crosses the surface (Fresnel
        reflection, Snell refraction at index `ior`), absorption per unit length inside.
        Returns its index."""
        return self._scene.add_material(_vec3("color", color), float(ka), float(kd), float(ks),
                                        float(shininess), float(glaze), float(transmission),
                                        float(ior), _vec3("absorption", absorption))

    @staticmethod
    def _material(material: Optional[int]) -> int:
        """The material index, or -1: the scene's default material (Material's defaults,
        added with the first object that asks for it)."""
        return -1 if material is None else _index("material", material)

    @staticmethod
    def _asset(asset: Optional[int]) -> int:
        return -1 if asset is None else _index("asset", asset)

    def add_asset(self, name: str = "") -> int:
        """A new, empty asset: objects added with ``asset=`` its index go into it instead
        of the scene, and are rendered only where add_instance() places them. Assets hold
        spheres, triangles, meshes and OBJ files (no planes, no instances). Returns its
        index."""
        return self._scene.add_asset(str(name))

    def add_instance(self, asset: int, transform: Any = None, material: Optional[int] = None,
                     mask: int = _ALL_BITS) -> int:
        """Places asset `asset` by `transform` (any invertible affine 4x4 map: rotation,
        uneven scale, mirroring), packed once however often it is placed; `material`
        replaces the asset's materials. Returns the instance's object index."""
        m = -1 if material is None else _index("material", material)
        return self._scene.add_instance(_index("asset", asset), m, _mask(mask),
                                        _transform(transform))

    def add_mesh(self, vertices: Any, triangles: Any, material: Optional[int] = None,
                 transform: Any = None, mask: int = _ALL_BITS,
                 asset: Optional[int] = None) -> int:
        """An indexed triangle mesh: vertices (n, 3) real numbers, triangles (m, 3)
        integer indices into them. Returns the object's index (in the asset, with
        `asset`)."""
        v = _rows("vertices", vertices, np.float64)
        t = _real_array("triangles", triangles)
        if t.dtype.kind not in "iu":
            raise ValueError(f"triangles: must hold integer indices, got dtype {t.dtype}")
        t = _rows("triangles", t, np.int64)
        return self._scene.add_mesh(v, t, self._material(material), _mask(mask),
                                    _transform(transform), self._asset(asset))

    def add_obj(self, path: PathLike, material: Optional[int] = None, transform: Any = None,
                mask: int = _ALL_BITS, asset: Optional[int] = None) -> int:
        """A Wavefront OBJ file, with its MTL materials and textures unless `material`
        overrides them. Returns the object's index (in the asset, with `asset`)."""
        m = -1 if material is None else _index("material", material)
        index, notes = self._scene.add_obj(os.fspath(path), m, _mask(mask), _transform(transform),
                                           self._asset(asset))
        for w in notes:
            warnings.warn(w, stacklevel=2)
        return index

    def add_sphere(self, center: Vector, radius: float, material: Optional[int] = None,
                   transform: Any = None, mask: int = _ALL_BITS,
                   asset: Optional[int] = None) -> int:
        """A sphere (radius > 0). Returns the object's index (in the asset, with
        `asset`)."""
        return self._scene.add_sphere(_vec3("center", center), float(radius),
                                      self._material(material), _mask(mask),
                                      _transform(transform), self._asset(asset))

    def add_plane(self, point: Vector, normal: Vector, material: Optional[int] = None,
                  transform: Any = None, mask: int = _ALL_BITS) -> int:
        """The infinite plane through `point` with `normal` (any non-zero length)."""
        return self._scene.add_plane(_vec3("point", point), _vec3("normal", normal),
                                     self._material(material), _mask(mask),
                                     _transform(transform))

    def add_triangle(self, a: Vector, b: Vector, c: Vector, material: Optional[int] = None,
                     transform: Any = None, mask: int = _ALL_BITS,
                     asset: Optional[int] = None) -> int:
        """One triangle, lit from both sides."""
        return self._scene.add_triangle(_vec3("a", a), _vec3("b", b), _vec3("c", c),
                                        self._material(material), _mask(mask),
                                        _transform(transform), self._asset(asset))

    def add_light(self, position: Vector, intensity: float = 1.0,
                  color: Vector = (1.0, 1.0, 1.0)) -> int:
        """A point light. Returns its index in `lights`."""
        self.lights.append(Light(_vec3("position", position), float(intensity),
                                 _vec3("color", color)))
        return len(self.lights) - 1

    def add_rect_light(self, corner: Vector, edge1: Vector, edge2: Vector,
                       intensity: float = 1.0, color: Vector = (1.0, 1.0, 1.0),
                       samples: int = 4) -> int:
        """A rectangular area light: corner + x edge1 + y edge2 for x, y in [0, 1], with
        samples x samples shadow samples. Returns its index in `lights`."""
        self.lights.append(Light(_vec3("corner", corner), float(intensity), _vec3("color", color),
                                 "rect", _vec3("edge1", edge1), _vec3("edge2", edge2), 0.0,
                                 _count("samples", samples)))
        return len(self.lights) - 1

    def add_sphere_light(self, center: Vector, radius: float, intensity: float = 1.0,
                         color: Vector = (1.0, 1.0, 1.0), samples: int = 4) -> int:
        """A spherical area light with samples x samples shadow samples. Returns its
        index in `lights`."""
        self.lights.append(Light(_vec3("center", center), float(intensity), _vec3("color", color),
                                 "sphere", radius=float(radius), samples=_count("samples", samples)))
        return len(self.lights) - 1

    def set_environment(self, path: Optional[PathLike], rotate_degrees: float = 0.0,
                        intensity: float = 1.0, up: Vector = (0.0, 1.0, 0.0)) -> None:
        """An equirectangular image (PNG, JPEG or Radiance HDR) that rays which hit
        nothing see instead of the background, its top row toward `up`; it does not
        light the scene. None removes it."""
        self._scene.set_environment("" if path is None else os.fspath(path),
                                    float(rotate_degrees), float(intensity), _vec3("up", up))

    @property
    def environment_file(self) -> Optional[str]:
        """The environment image's file (set here or by the scene file), or None."""
        return self._scene.environment_file or None

    @property
    def background(self) -> Tuple[float, float, float]:
        """The color of rays that hit nothing (linear RGB in [0, 1])."""
        return tuple(self._scene.background)

    @background.setter
    def background(self, color: Vector) -> None:
        self._scene.background = _vec3("background", color)

    @property
    def object_count(self) -> int:
        return self._scene.object_count

    @property
    def material_count(self) -> int:
        return self._scene.material_count

    @property
    def asset_count(self) -> int:
        return self._scene.asset_count


class Hits:
    """The closest hit of each ray of Tracer.intersect(), as arrays of n entries.

    t: distance in lengths of the ray's direction (inf for a miss); u, v: barycentric
    coordinates on a triangle (the surface parameters on other shapes); normal (n, 3):
    unit geometric normal facing the ray's origin; object: index in the scene (-1 for a
    miss); primitive: the triangle's index in its mesh (0 for other shapes, -1 for a miss);
    instance: -1, or for a hit inside an instance the instance's index in the scene, with
    object then the object's index in its asset.
    """

    __slots__ = ("t", "u", "v", "normal", "object", "primitive", "instance")

    def __init__(self, t: np.ndarray, u: np.ndarray, v: np.ndarray, normal: np.ndarray,
                 object: np.ndarray, primitive: np.ndarray, instance: np.ndarray) -> None:
        self.t, self.u, self.v, self.normal = t, u, v, normal
        self.object, self.primitive, self.instance = object, primitive, instance

    def __len__(self) -> int:
        return len(self.t)

    def __repr__(self) -> str:
        hit = int(np.count_nonzero(self.object >= 0))
        return f"<twinray.Hits: {len(self)} rays, {hit} hit>"


class Tracer:
    """Renders a scene and answers ray queries against it, on one backend.

    backend: "cpu", "opencl" (RuntimeError when there is no OpenCL device) or "auto"
    (OpenCL when there is a device, else the CPU); precision: "float" or "double";
    device: the OpenCL device index (twinray info lists them), -1 for the first.
    The scene is packed now, and again only when objects or materials change.
    """

    def __init__(self, scene: Scene, backend: str = "auto", precision: str = "float",
                 device: int = -1) -> None:
        if not isinstance(scene, Scene):
            raise ValueError(f"scene: must be a twinray.Scene, got {type(scene).__name__}")
        if backend not in ("cpu", "opencl", "auto"):
            raise ValueError(f'backend: must be "cpu", "opencl" or "auto", got {backend!r}')
        if precision not in ("float", "double"):
            raise ValueError(f'precision: must be "float" or "double", got {precision!r}')
        self.scene = scene
        self._dtype = np.float32 if precision == "float" else np.float64
        native = _core.TracerFloat if precision == "float" else _core.TracerDouble
        self._tracer = native(backend, _index("device", device))
        self._tracer.prepare(scene._scene)

    @property
    def backend(self) -> str:
        """The backend that runs: "cpu" or "opencl"."""
        return self._tracer.backend

    @property
    def device(self) -> str:
        """The device it runs on: the CPU's model, or the OpenCL device's name."""
        return self._tracer.device

    @property
    def precision(self) -> str:
        return "float" if self._dtype == np.float32 else "double"

    @property
    def dtype(self) -> np.dtype:
        """float32 or float64: the dtype of rays read in place and of results."""
        return np.dtype(self._dtype)

    @property
    def pack_count(self) -> int:
        """How many times this tracer has packed its scene."""
        return self._tracer.pack_count

    def render(self, spp: Optional[int] = None, aov: Optional[str] = None,
               max_depth: Optional[int] = None, shadows: Optional[bool] = None,
               glaze: Optional[bool] = None, sampler: Optional[str] = None,
               seed: Optional[int] = None) -> np.ndarray:
        """The image through scene.camera with scene.lights: (height, width, 3) linear
        RGB of the tracer's dtype. Options left None take the scene file's ``render``
        values (or the library's defaults: spp 1, max_depth 4, shadows and glaze on).

        aov: "depth" (height, width) distance along the primary ray, inf where nothing
        is hit; "normal" and "shading_normal" (height, width, 3); "uv" (height, width, 2);
        "object" (height, width) int32 object index, -1 where nothing is hit.
        """
        name = "shaded" if aov is None else aov
        if name == "shading-normal":
            name = "shading_normal"
        if name not in _AOVS:
            raise ValueError(f"aov: must be one of {', '.join(map(repr, _AOVS))}; got {aov!r}")
        spec = _core.RenderSpec()
        spec.aov = name
        if spp is not None:
            spec.spp = _index("spp", spp)
        if max_depth is not None:
            spec.max_depth = _index("max_depth", max_depth)
        if shadows is not None:
            spec.shadows = int(bool(shadows))
        if glaze is not None:
            spec.glaze = int(bool(glaze))
        if sampler is not None:
            spec.sampler = str(sampler)
        if seed is not None:
            spec.seed = _index("seed", seed)
        lights = [light._native(i) for i, light in enumerate(self.scene.lights)]
        image = self._tracer.render(self.scene._scene, self.scene.camera._native(), lights, spec)
        if name == "depth":
            return np.ascontiguousarray(image[:, :, 0])
        if name == "uv":
            return np.ascontiguousarray(image[:, :, :2])
        if name == "object":
            return image[:, :, 0].astype(np.int32)
        return image

    def _rays(self, origins: Any, directions: Any, tmin: Any, tmax: Any,
              mask: Any) -> Tuple[np.ndarray, ...]:
        o = _rows("origins", origins, self._dtype)
        d = _rows("directions", directions, self._dtype)
        if d.shape != o.shape:
            raise ValueError(f"directions: shape {d.shape} differs from origins' {o.shape}")
        n = o.shape[0]
        lo = self._per_ray("tmin", tmin, n, self._dtype)
        hi = self._per_ray("tmax", tmax, n, self._dtype)
        if mask is None:
            m = np.full(1, _ALL_BITS, dtype=np.uint32)
        else:
            a = _real_array("mask", mask)
            if a.dtype.kind not in "iu":
                raise ValueError(f"mask: must hold integers, got dtype {a.dtype}")
            if a.size and (a.min() < 0 or a.max() > _ALL_BITS):
                raise ValueError("mask: values must be in [0, 4294967295]")
            m = self._per_ray("mask", a, n, np.uint32)
        return o, d, lo, hi, m

    @staticmethod
    def _per_ray(name: str, value: Any, n: int, dtype: Any) -> np.ndarray:
        a = _real_array(name, value)
        if a.ndim == 0:
            return np.full(1, a, dtype=dtype)
        if a.shape != (n,):
            raise ValueError(f"{name}: must be one number or an array of shape ({n},), "
                             f"got shape {a.shape}")
        return np.ascontiguousarray(a, dtype=dtype)

    def intersect(self, origins: Any, directions: Any, tmin: Any = 0.0, tmax: Any = math.inf,
                  mask: Any = None) -> Hits:
        """The closest hit of each ray origins[i] + t directions[i], t in [tmin, tmax]
        (each one number or one per ray). Arrays of the tracer's dtype, C-contiguous,
        are read in place; others are converted once. A ray with a zero or non-finite
        direction, or a non-finite origin, misses. mask: objects whose mask shares no
        bit with the ray's are skipped (default: all bits)."""
        o, d, lo, hi, m = self._rays(origins, directions, tmin, tmax, mask)
        n = o.shape[0]
        dt = self._dtype
        hits = Hits(np.empty(n, dt), np.empty(n, dt), np.empty(n, dt), np.empty((n, 3), dt),
                    np.empty(n, np.int32), np.empty(n, np.int32), np.empty(n, np.int32))
        self._tracer.intersect(self.scene._scene, o, d, lo, hi, m, hits.t, hits.u, hits.v,
                               hits.normal, hits.object, hits.primitive, hits.instance)
        return hits

    def occluded(self, origins: Any, directions: Any, tmin: Any = 0.0, tmax: Any = math.inf,
                 mask: Any = None) -> np.ndarray:
        """Whether anything lies on each ray within [tmin, tmax]: (n,) bool, True exactly
        where intersect() finds a hit."""
        o, d, lo, hi, m = self._rays(origins, directions, tmin, tmax, mask)
        blocked = np.empty(o.shape[0], dtype=np.bool_)
        self._tracer.occluded(self.scene._scene, o, d, lo, hi, m, blocked.view(np.uint8))
        return blocked


def _image(image: Any) -> np.ndarray:
    a = _real_array("image", image)
    if a.ndim == 2:
        a = np.repeat(a[:, :, None], 3, axis=2)
    if a.ndim != 3 or a.shape[2] != 3:
        raise ValueError(f"image: must be (height, width, 3) or (height, width), got {a.shape}")
    return np.ascontiguousarray(a, dtype=np.float64 if a.dtype == np.float64 else np.float32)


def write_png(path: PathLike, image: Any) -> None:
    """Writes linear RGB values as an 8-bit sRGB PNG (clamped to [0, 1]), as the
    twinray command does. A (height, width) array is written as grey."""
    _core.write_png(os.fspath(path), _image(image))


def write_pfm(path: PathLike, image: Any) -> None:
    """Writes the values exactly as a PFM (32-bit floats; float64 is rounded once)."""
    _core.write_pfm(os.fspath(path), _image(image))


def opencl_available(device: int = -1) -> Tuple[bool, str]:
    """(True, "") when an OpenCL device is there, else (False, why)."""
    return tuple(_core.opencl_available(_index("device", device)))
