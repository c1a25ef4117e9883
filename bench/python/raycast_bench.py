#!/usr/bin/env python3
"""Closest-hit ray casting from Python: twinray against Open3D, embreex and trimesh.

Every library casts the same rays (float32 origins and unit directions) at the same triangles
and reports, per ray, the hit distance t and the index of the hit triangle. Two meshes: a
generated torus (a parametric grid with shared vertices, 1e6 triangles by default) and a mesh
read with trimesh (--mesh). Two ray sets per mesh: a pinhole camera looking at the mesh
(coherent) and random rays from random points inside the mesh's bounding box in uniformly
random directions (incoherent).

Timing: interleaved rounds. Each round casts every (mesh, ray set) with every library once, the
libraries in an order that rotates from round to round, and the table reports the median rays/s
over the rounds. Scene building is timed apart from casting: each library's build is followed by
a warm-up query of one ray, timed on its own. twinray packs the scene into its flat arrays in
Tracer() (timed as such); for the Embree-based libraries the first query commits the scene.

Agreement: each library's round-one answers are compared with twinray CPU's (or with the first
library that ran, when twinray cannot be imported): the share of rays whose hit triangle is the
same (both missing counts as the same), and the largest relative difference of t over rays that
hit the same triangle. twinray OpenCL must match twinray CPU bit for bit. --explain K prints up
to K disagreeing rays per comparator and classifies them by recomputing both hits in float64.

Each comparator whose import, build or query fails is reported and skipped.
"""

import argparse
import gc
import importlib.metadata
import math
import os
import platform
import resource
import sys
import time

import numpy as np

COMPARATORS = ("open3d", "embreex", "trimesh")
ALL_LIBRARIES = ("twinray-cpu", "twinray-opencl") + COMPARATORS


def log(msg):
    print(msg, file=sys.stderr, flush=True)


# --------------------------------------------------------------------------------------------
# Meshes


class Mesh:
    def __init__(self, name, vertices, triangles):
        self.name = name
        self.vertices = np.ascontiguousarray(vertices, dtype=np.float32)
        self.triangles = np.ascontiguousarray(triangles, dtype=np.int32)
        self.lo = self.vertices.min(axis=0).astype(np.float64)
        self.hi = self.vertices.max(axis=0).astype(np.float64)


def make_torus(n_triangles, major=1.0, minor=0.35):
    """A torus around the z axis as an nu x nv grid of quads, two triangles each, vertices shared
    across the seams; nu = 2 nv, so the quads are of similar size around both circles."""
    nv = max(3, int(round(math.sqrt(n_triangles / 4.0))))
    nu = max(3, n_triangles // (2 * nv))
    i = np.arange(nu, dtype=np.float64)[:, None]
    j = np.arange(nv, dtype=np.float64)[None, :]
    theta = 2.0 * np.pi * i / nu
    phi = 2.0 * np.pi * j / nv
    ring = major + minor * np.cos(phi)
    vertices = np.stack(
        [
            (ring * np.cos(theta)).ravel(),
            (ring * np.sin(theta)).ravel(),
            np.broadcast_to(minor * np.sin(phi), (nu, nv)).ravel(),
        ],
        axis=1,
    ).astype(np.float32)
    ii, jj = np.meshgrid(np.arange(nu), np.arange(nv), indexing="ij")
    a = ii * nv + jj
    b = ((ii + 1) % nu) * nv + jj
    c = ((ii + 1) % nu) * nv + (jj + 1) % nv
    d = ii * nv + (jj + 1) % nv
    triangles = np.empty((nu * nv * 2, 3), dtype=np.int32)
    triangles[0::2] = np.stack([a.ravel(), b.ravel(), c.ravel()], axis=1)
    triangles[1::2] = np.stack([a.ravel(), c.ravel(), d.ravel()], axis=1)
    return Mesh(f"torus ({len(triangles):,} triangles, generated)", vertices, triangles)


def load_mesh(path, label):
    import trimesh

    # process=False keeps the file's vertex and triangle order, so that triangle indices mean
    # the same thing to every library.
    m = trimesh.load(path, force="mesh", process=False)
    name = label or os.path.basename(path)
    return Mesh(f"{name} ({len(m.faces):,} triangles)", m.vertices, m.faces)


# --------------------------------------------------------------------------------------------
# Rays


class RaySet:
    def __init__(self, name, origins, directions):
        self.name = name
        self.origins = origins
        self.directions = directions
        self._rays6 = None

    def __len__(self):
        return len(self.origins)

    def rays6(self):
        """(n, 6) float32 [origin, direction] rows, as Open3D takes them; made once."""
        if self._rays6 is None:
            self._rays6 = np.empty((len(self), 6), dtype=np.float32)
            self._rays6[:, :3] = self.origins
            self._rays6[:, 3:] = self.directions
        return self._rays6


def camera_rays(mesh, n, aspect=1.6):
    """A pinhole camera outside the mesh's bounding sphere, looking at the centre of its bounding
    box from an oblique direction, the frame fitted to the projected vertices; w x h pixels
    with w / h close to aspect (4000 x 2500 for 1e7 rays), row by row, cut to n rays."""
    w = max(1, int(round(math.sqrt(n * aspect))))
    h = (n + w - 1) // w
    centre = 0.5 * (mesh.lo + mesh.hi)
    radius = 0.5 * float(np.linalg.norm(mesh.hi - mesh.lo))
    forward = -np.array([0.6, -0.6, 0.5])
    forward /= np.linalg.norm(forward)
    eye = centre - 2.5 * radius * forward
    right = np.cross(forward, [0.0, 0.0, 1.0])
    right /= np.linalg.norm(right)
    up = np.cross(right, forward)
    step = max(1, len(mesh.vertices) // 200_000)  # a subsample of vertices is enough to frame
    rel = mesh.vertices[::step].astype(np.float64) - eye
    depth = rel @ forward
    tan_half = 1.02 * max(
        np.max(np.abs(rel @ right) / depth) / aspect, np.max(np.abs(rel @ up) / depth)
    )
    directions = np.empty((n, 3), dtype=np.float32)
    xs = (2.0 * (np.arange(w) + 0.5) / w - 1.0) * tan_half * aspect
    rows = max(1, (1 << 21) // w)  # a few MB of float64 at a time
    for y0 in range(0, h, rows):
        y1 = min(h, y0 + rows)
        ys = (1.0 - 2.0 * (np.arange(y0, y1) + 0.5) / h) * tan_half
        d = forward + xs[None, :, None] * right + ys[:, None, None] * up
        d = d.reshape(-1, 3)
        d /= np.linalg.norm(d, axis=1, keepdims=True)
        k0 = y0 * w
        k1 = min(n, y1 * w)
        if k1 > k0:
            directions[k0:k1] = d[: k1 - k0]
    origins = np.empty((n, 3), dtype=np.float32)
    origins[:] = eye.astype(np.float32)
    return RaySet(
        f"camera {w}x{h}" + ("" if w * h == n else f" (first {n:,})"), origins, directions
    )


def random_rays(mesh, n, seed):
    rng = np.random.default_rng(seed)
    origins = np.empty((n, 3), dtype=np.float32)
    directions = np.empty((n, 3), dtype=np.float32)
    step = 1 << 20
    lo = mesh.lo.astype(np.float32)
    ext = (mesh.hi - mesh.lo).astype(np.float32)
    for k in range(0, n, step):
        m = min(n, k + step) - k
        origins[k : k + m] = lo + ext * rng.random((m, 3), dtype=np.float32)
        d = rng.standard_normal((m, 3)).astype(np.float64)
        d /= np.linalg.norm(d, axis=1, keepdims=True)
        directions[k : k + m] = d
    return RaySet("random in bbox", origins, directions)


# --------------------------------------------------------------------------------------------
# Libraries. Each has build(mesh) -> (state, {phase: seconds}) and cast(state, rays) -> raw,
# where only cast is timed in the rounds; answers(raw) turns raw into a dict of numpy arrays
# t (inf on a miss), prim (-1 on a miss) and, where the library reports them, u and v.


def one_ray(mesh):
    """A single ray towards the mesh's centre, for warm-up queries."""
    centre = 0.5 * (mesh.lo + mesh.hi)
    o = np.array([[centre[0], centre[1], mesh.hi[2] + 1.0]], dtype=np.float32)
    d = np.array([[0.0, 0.0, -1.0]], dtype=np.float32)
    return RaySet("one", o, d)


class Twinray:
    def __init__(self, backend):
        import twinray

        self.tr = twinray
        self.backend = backend
        self.name = f"twinray-{backend}"
        self.version = getattr(twinray, "__version__", None) or _dist_version("twinray")

    def build(self, mesh):
        tr = self.tr
        times = {}
        t0 = time.perf_counter()
        scene = tr.Scene()
        m = scene.add_material(color=(0.8, 0.8, 0.8))
        scene.add_mesh(mesh.vertices, mesh.triangles, material=m)
        times["scene"] = time.perf_counter() - t0
        t0 = time.perf_counter()
        # Tracer() packs the scene into the flat arrays the kernels read (pack_count says how
        # often it has packed: the casting rounds must not add to it).
        tracer = tr.Tracer(scene, backend=self.backend, precision="float")
        times["Tracer() (packs)"] = time.perf_counter() - t0
        # The first query sets up the backend's per-query state (OpenCL: the program and its
        # buffers); timed on one ray so that the rounds time casting only.
        warm = one_ray(mesh)
        t0 = time.perf_counter()
        tracer.intersect(warm.origins, warm.directions)
        times["first 1-ray query"] = time.perf_counter() - t0
        return (scene, tracer), times

    def cast(self, state, rays):
        return state[1].intersect(rays.origins, rays.directions)

    @staticmethod
    def answers(raw):
        return {
            "t": np.asarray(raw.t),
            "prim": np.asarray(raw.primitive),
            "u": np.asarray(raw.u),
            "v": np.asarray(raw.v),
        }

    @staticmethod
    def fields(raw):
        """Every array of a Hits, for the bitwise OpenCL-against-CPU comparison."""
        return {
            k: np.asarray(getattr(raw, k)) for k in ("t", "object", "primitive", "u", "v", "normal")
        }


class Open3D:
    name = "open3d"

    def __init__(self):
        import open3d as o3d

        self.o3d = o3d
        self.version = o3d.__version__

    def build(self, mesh):
        o3d = self.o3d
        t0 = time.perf_counter()
        scene = o3d.t.geometry.RaycastingScene()
        scene.add_triangles(
            o3d.core.Tensor.from_numpy(mesh.vertices),
            o3d.core.Tensor.from_numpy(mesh.triangles.astype(np.uint32)),
        )
        times = {"scene": time.perf_counter() - t0}
        # Open3D commits the Embree scene on the first query.
        warm = one_ray(mesh)
        t0 = time.perf_counter()
        scene.cast_rays(o3d.core.Tensor.from_numpy(warm.rays6()))
        times["first 1-ray query (commit)"] = time.perf_counter() - t0
        return scene, times

    def prepare(self, rays):
        """The (n, 6) float32 tensor, made before the timed call (it shares rays6's memory)."""
        return self.o3d.core.Tensor.from_numpy(rays.rays6())

    def cast(self, state, rays):
        # All rays in one call, nthreads=0: Open3D's own thread pool picks the thread count.
        return state.cast_rays(rays, nthreads=0)

    @staticmethod
    def answers(raw):
        prim = raw["primitive_ids"].numpy().view(np.int32).copy()  # INVALID_ID (2^32 - 1) reads -1
        uv = raw["primitive_uvs"].numpy().copy()
        return {"t": raw["t_hit"].numpy().copy(), "prim": prim, "u": uv[:, 0], "v": uv[:, 1]}


class Embreex:
    name = "embreex"

    def __init__(self):
        from embreex import mesh_construction, rtcore_scene

        self.mc = mesh_construction
        self.rs = rtcore_scene
        self.version = _dist_version("embreex")

    def build(self, mesh):
        t0 = time.perf_counter()
        scene = self.rs.EmbreeScene()
        self.mc.TriangleMesh(scene, mesh.vertices, mesh.triangles)
        times = {"scene": time.perf_counter() - t0}
        warm = one_ray(mesh)
        t0 = time.perf_counter()
        scene.run(warm.origins, warm.directions, output=1)
        times["first 1-ray query (commit)"] = time.perf_counter() - t0
        return scene, times

    def cast(self, state, rays):
        # embreex's only batch call: a loop of rtcIntersect1 over the rays, on the calling
        # thread; output=1 returns t, u, v, the normal and the ids.
        return state.run(rays.origins, rays.directions, output=1)

    @staticmethod
    def answers(raw):
        prim = raw["primID"]
        t = raw["tfar"]
        t[prim < 0] = np.inf  # a miss keeps the initial tfar (1e37)
        return {"t": t, "prim": prim, "u": raw["u"], "v": raw["v"]}


class Trimesh:
    name = "trimesh"

    def __init__(self):
        import trimesh
        from trimesh.ray import ray_pyembree

        self.trimesh = trimesh
        self.rp = ray_pyembree
        self.version = trimesh.__version__

    def build(self, mesh):
        t0 = time.perf_counter()
        tm = self.trimesh.Trimesh(mesh.vertices, mesh.triangles, process=False)
        inter = self.rp.RayMeshIntersector(tm)
        inter._scene  # noqa: B018 - builds the embreex scene, which trimesh makes on first use
        times = {"scene": time.perf_counter() - t0}
        warm = one_ray(mesh)
        t0 = time.perf_counter()
        inter.intersects_first(warm.origins, warm.directions)
        times["first 1-ray query (commit)"] = time.perf_counter() - t0
        return inter, times

    def cast(self, state, rays):
        return state.intersects_first(rays.origins, rays.directions)

    @staticmethod
    def answers(raw):
        # intersects_first gives the triangle index only; no t, no barycentrics.
        return {"t": None, "prim": np.asarray(raw, dtype=np.int32), "u": None, "v": None}


def _dist_version(name):
    try:
        return importlib.metadata.version(name)
    except importlib.metadata.PackageNotFoundError:
        return "?"


def load_libraries(wanted):
    libs, skipped = [], []
    makers = {
        "twinray-cpu": lambda: Twinray("cpu"),
        "twinray-opencl": lambda: Twinray("opencl"),
        "open3d": Open3D,
        "embreex": Embreex,
        "trimesh": Trimesh,
    }
    for name in wanted:
        try:
            libs.append(makers[name]())
        except Exception as e:  # an import failure skips the library, it does not end the run
            skipped.append((name, f"import failed: {type(e).__name__}: {e}"))
    return libs, skipped


# --------------------------------------------------------------------------------------------
# Agreement and its explanation


def rel_diff(a, b):
    a = a.astype(np.float64)
    b = b.astype(np.float64)
    return np.abs(a - b) / np.maximum(np.abs(b), np.finfo(np.float64).tiny)


def agreement(ref, other, diag):
    """Share of rays with the same hit triangle (misses agree with misses) and the largest
    relative difference of t where both hit the same triangle, also as an absolute difference
    over the mesh's bounding-box diagonal (the relative one grows without bound as t -> 0, when
    a ray starts on the surface)."""
    same = ref["prim"] == other["prim"]
    share = float(np.count_nonzero(same)) / len(same)
    both = same & (ref["prim"] >= 0)
    max_rel = max_abs = None
    if other["t"] is not None and np.any(both):
        a = other["t"][both].astype(np.float64)
        b = ref["t"][both].astype(np.float64)
        max_rel = float(rel_diff(a, b).max())
        max_abs = float(np.abs(a - b).max()) / diag
    return {
        "same": share,
        "differ": int(len(same) - np.count_nonzero(same)),
        "max_rel_t": max_rel,
        "max_abs_t": max_abs,
        "hits_ref": int(np.count_nonzero(ref["prim"] >= 0)),
        "hits": int(np.count_nonzero(other["prim"] >= 0)),
    }


def intersect64(o, d, v0, v1, v2):
    """Moller-Trumbore (Moller & Trumbore 1997) in float64 for rows of rays and triangles:
    t and the barycentrics (u at v1, v at v2, w = 1 - u - v at v0), without the inside test,
    so that a hit just outside an edge shows as a small negative barycentric."""
    e1 = v1 - v0
    e2 = v2 - v0
    p = np.cross(d, e2)
    det = np.einsum("ij,ij->i", e1, p)
    with np.errstate(divide="ignore", invalid="ignore"):
        inv = 1.0 / det
        s = o - v0
        u = np.einsum("ij,ij->i", s, p) * inv
        q = np.cross(s, e1)
        v = np.einsum("ij,ij->i", d, q) * inv
        t = np.einsum("ij,ij->i", e2, q) * inv
    return t, u, v, 1.0 - u - v


def t_error64(mesh, rays, ans, chunk=1 << 20):
    """How far a library's t lies from float64 Moller-Trumbore on the triangle the library
    reports, over the rays it hits: the largest |t - t64| over the bounding-box diagonal, and
    the median and largest |t - t64| / t64."""
    hit = np.flatnonzero(ans["prim"] >= 0)
    if not len(hit):
        return None
    vx = mesh.vertices
    max_abs = 0.0
    rels = np.empty(len(hit), dtype=np.float32)
    for k in range(0, len(hit), chunk):
        idx = hit[k : k + chunk]
        tri = mesh.triangles[ans["prim"][idx]]
        t64, _, _, _ = intersect64(
            rays.origins[idx].astype(np.float64),
            rays.directions[idx].astype(np.float64),
            vx[tri[:, 0]].astype(np.float64),
            vx[tri[:, 1]].astype(np.float64),
            vx[tri[:, 2]].astype(np.float64),
        )
        err = np.abs(ans["t"][idx].astype(np.float64) - t64)
        max_abs = max(max_abs, float(err.max()))
        rels[k : k + len(idx)] = err / np.abs(t64)
    diag = float(np.linalg.norm(mesh.hi - mesh.lo))
    return {
        "max_abs": max_abs / diag,
        "median_rel": float(np.median(rels)),
        "max_rel": float(rels.max()),
    }


class Explainer:
    """Classifies the rays where a comparator and the reference disagree: a different hit
    triangle (or one misses), or the same triangle with t more than --precision-rel apart."""

    CLASSES = ("tie", "grazing/edge", "precision", "other")

    def __init__(self, mesh, rays, edge_eps, tie_rel, precision_rel):
        self.mesh = mesh
        self.rays = rays
        self.edge_eps = edge_eps
        self.tie_rel = tie_rel
        self.precision_rel = precision_rel

    def _geometry(self, idx, prim):
        o = self.rays.origins[idx].astype(np.float64)
        d = self.rays.directions[idx].astype(np.float64)
        hit = prim >= 0
        tri = self.mesh.triangles[np.where(hit, prim, 0)]
        vx = self.mesh.vertices
        v0 = vx[tri[:, 0]].astype(np.float64)
        v1 = vx[tri[:, 1]].astype(np.float64)
        v2 = vx[tri[:, 2]].astype(np.float64)
        t, u, v, w = intersect64(o, d, v0, v1, v2)
        bary_min = np.min(np.abs(np.stack([u, v, w], axis=1)), axis=1)
        # How far float32 barycentrics can stray: Moller-Trumbore divides by
        # det = d . (e1 x e2) = |e1 x e2| cos(theta), and its numerators carry rounding of the
        # order of 2^-24 |o - v0| |e|; so the error grows with the distance over the triangle's
        # size and with 1 / |cos(theta)| for rays that graze the triangle's plane.
        n = np.cross(v1 - v0, v2 - v0)
        n_len = np.linalg.norm(n, axis=1)
        with np.errstate(divide="ignore", invalid="ignore"):
            cos = np.abs(np.einsum("ij,ij->i", d, n)) / (n_len * np.linalg.norm(d, axis=1))
            edge = np.max(
                np.stack(
                    [
                        np.linalg.norm(v1 - v0, axis=1),
                        np.linalg.norm(v2 - v1, axis=1),
                        np.linalg.norm(v0 - v2, axis=1),
                    ],
                    axis=1,
                ),
                axis=1,
            )
            bound = 8.0 * 2.0**-24 * np.linalg.norm(o - v0, axis=1) * edge / (n_len * cos)
        tol = np.maximum(self.edge_eps, np.nan_to_num(bound, nan=np.inf))
        nan = np.full(len(idx), np.nan)
        return {
            "hit": hit,
            "tri": tri,
            "t64": np.where(hit, t, nan),
            "u": np.where(hit, u, nan),
            "v": np.where(hit, v, nan),
            "w": np.where(hit, w, nan),
            "bary_min": np.where(hit, bary_min, np.inf),
            "cos": np.where(hit, cos, nan),
            "tol": np.where(hit, tol, nan),
            "near_edge": hit & (bary_min < tol),
        }

    def classify(self, ref, other, cap=1_000_000):
        rp, op = ref["prim"], other["prim"]
        cand = rp != op
        if other["t"] is not None:
            same_hit = (rp == op) & (rp >= 0)
            cand |= same_hit & (rel_diff(other["t"], ref["t"]) > self.precision_rel)
        idx = np.flatnonzero(cand)
        total = len(idx)
        idx = idx[:cap]
        a = self._geometry(idx, rp[idx])
        b = self._geometry(idx, op[idx])
        ta = ref["t"][idx].astype(np.float64)
        # trimesh reports no t: its hit's t is the float64 one on its triangle.
        tb = other["t"][idx].astype(np.float64) if other["t"] is not None else b["t64"]
        same_tri = rp[idx] == op[idx]
        both = a["hit"] & b["hit"]
        shared = np.zeros(len(idx), dtype=bool)
        for i in range(3):
            for j in range(3):
                shared |= a["tri"][:, i] == b["tri"][:, j]
        with np.errstate(invalid="ignore"):
            close = both & (np.abs(ta - tb) <= self.tie_rel * np.maximum(np.abs(ta), np.abs(tb)))
        grazing = a["near_edge"] | b["near_edge"]
        cls = np.full(len(idx), 3, dtype=np.int8)  # other
        cls[~same_tri & grazing] = 1
        cls[~same_tri & close & shared & both] = 0
        cls[same_tri] = 2
        counts = {name: int(np.count_nonzero(cls == k)) for k, name in enumerate(self.CLASSES)}
        # Rays that start (nearly) on the surface: there t is tiny, and its relative error large,
        # while the absolute error stays far below the rounding of the coordinates.
        diag = float(np.linalg.norm(self.mesh.hi - self.mesh.lo))
        counts["short"] = int(np.count_nonzero((cls == 2) & (np.abs(ta) < 1e-3 * diag)))
        return {
            "total": total,
            "classified": len(idx),
            "counts": counts,
            "idx": idx,
            "cls": cls,
            "a": a,
            "b": b,
            "ta": ta,
            "tb": tb,
            "b_has_t": other["t"] is not None,
            "prim_a": rp[idx],
            "prim_b": op[idx],
        }

    def lines(self, res, k, ref_name, other_name):
        """Up to k rays, taken from the classes in turn (other, grazing/edge, precision, tie),
        so that the rare classes are shown too."""
        per_class = [list(np.flatnonzero(res["cls"] == c)) for c in (3, 1, 2, 0)]
        picked = []
        while len(picked) < k and any(per_class):
            for rows in per_class:
                if rows and len(picked) < k:
                    picked.append(rows.pop(0))
        out = []
        for n in sorted(picked):
            i = res["idx"][n]
            o = self.rays.origins[i]
            d = self.rays.directions[i]
            out.append(
                f"  ray {i}: o=({o[0]:.6g}, {o[1]:.6g}, {o[2]:.6g}) d=({d[0]:.6g}, {d[1]:.6g}, {d[2]:.6g})"
                f"  -> {self.CLASSES[res['cls'][n]]}"
            )
            for who, g, t in (
                (ref_name, res["a"], f"{res['ta'][n]:.9g}"),
                (other_name, res["b"], f"{res['tb'][n]:.9g}" if res["b_has_t"] else "n/a"),
            ):
                if not g["hit"][n]:
                    out.append(f"    {who:>15}: miss")
                    continue
                out.append(
                    f"    {who:>15}: triangle #{int(res['prim_a' if g is res['a'] else 'prim_b'][n])}"
                    f" (vertices {int(g['tri'][n][0])},{int(g['tri'][n][1])},{int(g['tri'][n][2])})"
                    f" t={t}; float64 on that triangle: t={g['t64'][n]:.9g}"
                    f" u={g['u'][n]:.3g} v={g['v'][n]:.3g} 1-u-v={g['w'][n]:.3g}"
                    f" |cos|={g['cos'][n]:.2g} edge tol={g['tol'][n]:.2g}"
                )
        return out


# --------------------------------------------------------------------------------------------
# Output


class Table:
    def __init__(self, title, header):
        self.title = title
        self.header = header
        self.rows = []

    def add(self, *row):
        self.rows.append([str(c) for c in row])

    def render(self, markdown):
        if markdown:
            out = [
                f"**{self.title}**",
                "",
                "| " + " | ".join(self.header) + " |",
                "|" + "|".join("---" for _ in self.header) + "|",
            ]
            out += ["| " + " | ".join(r) + " |" for r in self.rows]
            return "\n".join(out) + "\n"
        widths = [
            max(len(h), *(len(r[i]) for r in self.rows)) if self.rows else len(h)
            for i, h in enumerate(self.header)
        ]
        line = "  ".join("-" * w for w in widths)
        out = [self.title, line, "  ".join(h.ljust(w) for h, w in zip(self.header, widths)), line]
        out += ["  ".join(c.ljust(w) for c, w in zip(r, widths)) for r in self.rows]
        return "\n".join(out) + "\n"


def fmt_rate(x):
    return f"{x / 1e6:.2f}" if x is not None else "-"


def fmt_share(x):
    if x == 1.0:
        return "100%"
    digits = 4
    while f"{100.0 * x:.{digits}f}" == "100." + "0" * digits:  # never round a difference away
        digits += 1
    return f"{100.0 * x:.{digits}f}%"


# --------------------------------------------------------------------------------------------


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--rays", type=float, default=1e7, help="rays per ray set (default 1e7)")
    ap.add_argument("--rounds", type=int, default=3, help="interleaved timing rounds (default 3)")
    ap.add_argument("--mesh", help="OBJ or PLY file for the second mesh, read with trimesh")
    ap.add_argument("--mesh-label", help="name for --mesh in the tables")
    ap.add_argument(
        "--torus-triangles", type=float, default=1e6, help="default 1e6; 0 leaves the torus out"
    )
    ap.add_argument(
        "--libraries",
        default=",".join(ALL_LIBRARIES),
        help="comma-separated subset of " + ", ".join(ALL_LIBRARIES),
    )
    ap.add_argument(
        "--explain",
        type=int,
        default=3,
        metavar="K",
        help="print up to K disagreeing rays per comparator, mesh and ray set, "
        "taking the classes in turn (default 3)",
    )
    ap.add_argument(
        "--edge-eps",
        type=float,
        default=1e-4,
        help="smallest barycentric tolerance of a grazing/edge hit (the float32 error scale "
        "of the ray and triangle can raise it)",
    )
    ap.add_argument("--tie-rel", type=float, default=1e-6, help="relative t difference of a tie")
    ap.add_argument(
        "--precision-rel",
        type=float,
        default=1e-5,
        help="relative t difference on the same triangle counted as disagreeing",
    )
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--markdown", action="store_true", help="print the tables as Markdown")
    args = ap.parse_args(argv)

    n = int(args.rays)
    if n < 1 or args.rounds < 1:
        ap.error("--rays and --rounds must be at least 1")
    wanted = [s.strip() for s in args.libraries.split(",") if s.strip()]
    bad = [s for s in wanted if s not in ALL_LIBRARIES]
    if bad:
        ap.error(f"unknown library {', '.join(bad)}; choose from {', '.join(ALL_LIBRARIES)}")

    libs, skipped = load_libraries(wanted)
    for name, why in skipped:
        log(f"skipping {name}: {why}")
    if not libs:
        log("no library could be imported")
        return 1

    meshes = []
    if args.torus_triangles >= 1:
        meshes.append(make_torus(int(args.torus_triangles)))
    if args.mesh:
        try:
            meshes.append(load_mesh(args.mesh, args.mesh_label))
        except Exception as e:
            log(f"cannot read --mesh {args.mesh}: {type(e).__name__}: {e}")
            return 1
    if not meshes:
        ap.error("no mesh: give --mesh or a non-zero --torus-triangles")

    log(f"making {n:,} camera and {n:,} random rays per mesh")
    raysets = [[camera_rays(m, n), random_rays(m, n, args.seed + k)] for k, m in enumerate(meshes)]

    # Builds, once per library and mesh.
    states = {}
    build_times = {}
    for mi, mesh in enumerate(meshes):
        for lib in libs:
            if lib.name in dict(skipped):
                continue
            log(f"building {lib.name} on {mesh.name}")
            try:
                states[lib.name, mi], build_times[lib.name, mi] = lib.build(mesh)
            except Exception as e:
                skipped.append((lib.name, f"build failed on {mesh.name}: {type(e).__name__}: {e}"))
                log(f"skipping {lib.name}: {skipped[-1][1]}")
    libs = [lib for lib in libs if lib.name not in dict(skipped)]
    names = [lib.name for lib in libs]
    ref_name = "twinray-cpu" if "twinray-cpu" in names else (names[0] if names else None)
    if ref_name is None:
        log("no library could build the scenes")
        return 1

    rates = {}  # (lib, mesh, set) -> [rays/s per round]
    agree = {}  # (lib, mesh, set) -> agreement dict
    bitwise = {}  # (mesh, set) -> bool, twinray OpenCL against CPU
    explained = {}  # (lib, mesh, set) -> (Explainer, result)
    accuracy = {}  # (lib, mesh, set) -> t_error64 dict
    load_before = os.getloadavg()
    slot = 0
    for r in range(args.rounds):
        for mi, mesh in enumerate(meshes):
            for si, rays in enumerate(raysets[mi]):
                order = libs[slot % len(libs) :] + libs[: slot % len(libs)]
                slot += 1
                kept = {}
                for lib in order:
                    if lib.name in dict(skipped):
                        continue
                    arg = lib.prepare(rays) if hasattr(lib, "prepare") else rays
                    gc.collect()
                    try:
                        t0 = time.perf_counter()
                        raw = lib.cast(states[lib.name, mi], arg)
                        dt = time.perf_counter() - t0
                    except Exception as e:
                        skipped.append(
                            (
                                lib.name,
                                f"query failed on {mesh.name}, {rays.name}: {type(e).__name__}: {e}",
                            )
                        )
                        log(f"skipping {lib.name}: {skipped[-1][1]}")
                        continue
                    rates.setdefault((lib.name, mi, si), []).append(len(rays) / dt)
                    log(
                        f"round {r + 1} {mesh.name} {rays.name} {lib.name}: {len(rays) / dt / 1e6:.2f} Mrays/s"
                    )
                    if r == 0:
                        kept[lib.name] = (
                            lib.answers(raw),
                            Twinray.fields(raw) if lib.name.startswith("twinray") else None,
                        )
                    del raw, arg
                if r == 0 and ref_name in kept:
                    ref = kept[ref_name][0]
                    for name, (ans, _) in kept.items():
                        if name == ref_name:
                            continue
                        agree[name, mi, si] = agreement(
                            ref, ans, float(np.linalg.norm(mesh.hi - mesh.lo))
                        )
                        ex = Explainer(mesh, rays, args.edge_eps, args.tie_rel, args.precision_rel)
                        explained[name, mi, si] = (ex, ex.classify(ref, ans))
                    if "twinray-cpu" in kept and "twinray-opencl" in kept:
                        a, b = kept["twinray-cpu"][1], kept["twinray-opencl"][1]
                        bitwise[mi, si] = all(np.array_equal(a[k], b[k]) for k in a)
                    for name, (ans, _) in kept.items():
                        if ans["t"] is not None and name != "twinray-opencl":
                            accuracy[name, mi, si] = t_error64(mesh, rays, ans)
                del kept
        log(f"round {r + 1} of {args.rounds} done")
    load_after = os.getloadavg()

    # ---------------------------------------------------------------- report
    md = args.markdown
    out = []
    out.append(f"{'## ' if md else ''}Closest-hit ray casting from Python")
    out.append("")
    cpu = platform.processor() or platform.machine()
    try:
        with open("/proc/cpuinfo") as f:
            cpu = next(line.split(":", 1)[1].strip() for line in f if line.startswith("model name"))
    except (OSError, StopIteration):
        pass
    out.append(
        f"{n:,} rays per ray set, {args.rounds} interleaved rounds, median over rounds; "
        f"{os.cpu_count()} logical CPUs ({cpu}); Python {platform.python_version()}, numpy {np.__version__}."
    )
    out.append(
        "Load average (1, 5, 15 min) before the rounds: "
        + ", ".join(f"{x:.2f}" for x in load_before)
        + "; after: "
        + ", ".join(f"{x:.2f}" for x in load_after)
        + "."
    )
    out.append("Versions: " + ", ".join(f"{lib.name} {lib.version}" for lib in libs) + ".")
    out.append("Meshes: " + "; ".join(m.name for m in meshes) + ".")
    for name, why in skipped:
        out.append(f"Skipped {name}: {why}")
    if "embreex" in names:
        out.append(
            "embreex's run() is a loop of rtcIntersect1 on the calling thread (it has no packet "
            "or multi-threaded batch call); trimesh's intersects_first calls it after scaling the "
            "mesh and the origins to a 100-unit box in float64 and back to float32."
        )
    out.append("")

    bt = Table("Build (seconds; once per mesh, not part of casting)", ["library", "mesh", "phases"])
    for mi, mesh in enumerate(meshes):
        for lib in libs:
            if (lib.name, mi) in build_times:
                bt.add(
                    lib.name,
                    mesh.name,
                    ", ".join(f"{k} {v:.3f}" for k, v in build_times[lib.name, mi].items()),
                )
    out.append(bt.render(md))
    if any(n.startswith("twinray") for n in names):
        packs = ", ".join(
            f"{name} on {meshes[mi].name}: {states[name, mi][1].pack_count}"
            for (name, mi) in sorted(states)
            if name.startswith("twinray")
        )
        out.append(
            "twinray: scene = Scene() + add_material + add_mesh; Tracer() packs the scene into "
            "the arrays the kernels read; the first query (one ray) is timed apart, so the casting "
            f"rounds below exclude packing and set-up. Tracer.pack_count after all rounds: {packs}.\n"
        )

    ct = Table(
        "Casting (million rays/s: median [per round]; twinray-cpu / fastest comparator)",
        ["mesh", "rays"] + names + ["cpu/fastest (median [per round])"],
    )
    for mi, mesh in enumerate(meshes):
        for si, rays in enumerate(raysets[mi]):
            cells = []
            for name in names:
                rs = rates.get((name, mi, si))
                cells.append(
                    f"{fmt_rate(float(np.median(rs)))} [{' '.join(fmt_rate(x) for x in rs)}]"
                    if rs
                    else "-"
                )
            ratio = "-"
            comps = [c for c in COMPARATORS if (c, mi, si) in rates]
            cpu_r = rates.get(("twinray-cpu", mi, si))
            if cpu_r and comps:
                k = min(len(cpu_r), *(len(rates[c, mi, si]) for c in comps))
                per = [cpu_r[i] / max(rates[c, mi, si][i] for c in comps) for i in range(k)]
                ratio = f"{np.median(per):.2f} [{' '.join(f'{x:.2f}' for x in per)}]"
            ct.add(mesh.name, rays.name, *cells, ratio)
    out.append(ct.render(md))

    at = Table(
        f"Agreement with {ref_name} (round one)",
        [
            "mesh",
            "rays",
            "library",
            "same triangle",
            "rays differing",
            f"hits ({ref_name})",
            "hits",
            "max rel. t diff, same triangle",
            "max abs. t diff / bbox diagonal",
            "OpenCL bitwise = CPU",
        ],
    )
    for mi, mesh in enumerate(meshes):
        for si, rays in enumerate(raysets[mi]):
            for name in names:
                a = agree.get((name, mi, si))
                if a is None:
                    continue
                bw = (
                    ("yes" if bitwise[mi, si] else "NO")
                    if name == "twinray-opencl" and (mi, si) in bitwise
                    else ""
                )
                mr = "n/a (no t)" if a["max_rel_t"] is None else f"{a['max_rel_t']:.3g}"
                ma = "n/a (no t)" if a["max_abs_t"] is None else f"{a['max_abs_t']:.3g}"
                at.add(
                    mesh.name,
                    rays.name,
                    name,
                    fmt_share(a["same"]),
                    f"{a['differ']:,}",
                    f"{a['hits_ref']:,}",
                    f"{a['hits']:,}",
                    mr,
                    ma,
                    bw,
                )
    out.append(at.render(md))
    if bitwise:
        out.append(
            "OpenCL bitwise = CPU: np.array_equal on every Hits array (t, object, primitive, u, v, normal).\n"
        )

    ac = Table(
        "t against float64 Moller-Trumbore on the library's own hit triangle (round one)",
        [
            "mesh",
            "rays",
            "library",
            "max abs. error / bbox diagonal",
            "median rel. error",
            "max rel. error",
        ],
    )
    for mi, mesh in enumerate(meshes):
        for si, rays in enumerate(raysets[mi]):
            for name in names:
                e = accuracy.get((name, mi, si))
                if e is not None:
                    ac.add(
                        mesh.name,
                        rays.name,
                        name,
                        f"{e['max_abs']:.3g}",
                        f"{e['median_rel']:.3g}",
                        f"{e['max_rel']:.3g}",
                    )
    if accuracy:
        out.append(ac.render(md))

    et = Table(
        f"Disagreements with {ref_name}, classified (different triangle, or same triangle with "
        f"t more than {args.precision_rel:g} relative apart)",
        ["mesh", "rays", "library", "disagreeing"]
        + list(Explainer.CLASSES)
        + ["precision with t < 0.001 x bbox diagonal"],
    )
    for mi, mesh in enumerate(meshes):
        for si, rays in enumerate(raysets[mi]):
            for name in names:
                e = explained.get((name, mi, si))
                if e is None:
                    continue
                res = e[1]
                note = (
                    ""
                    if res["classified"] == res["total"]
                    else f" (first {res['classified']:,} classified)"
                )
                et.add(
                    mesh.name,
                    rays.name,
                    name,
                    f"{res['total']:,}{note}",
                    *(f"{res['counts'][c]:,}" for c in (*Explainer.CLASSES, "short")),
                )
    out.append(et.render(md))
    out.append(
        f"tie: both t within {args.tie_rel:g} relative and the triangles share a vertex; "
        f"grazing/edge: a barycentric of either hit (recomputed in float64) smaller in magnitude "
        f"than max({args.edge_eps:g}, 8 * 2^-24 * |o - v0| * longest edge / (|e1 x e2| * |cos|)), "
        "the float32 barycentrics' error scale, which grows for distant and grazing rays (|cos| "
        "between the ray and the triangle's normal); "
        f"precision: same triangle, t more than {args.precision_rel:g} relative apart; "
        "other: the rest.\n"
    )

    if args.explain > 0 and explained:
        ex_lines = [
            f"{'### ' if md else ''}Disagreeing rays (up to {args.explain} per comparator, mesh and ray set)",
            "",
        ]
        if md:
            ex_lines.append("```")
        for mi, mesh in enumerate(meshes):
            for si, rays in enumerate(raysets[mi]):
                for name in names:
                    e = explained.get((name, mi, si))
                    if e is None or not len(e[1]["idx"]):
                        continue
                    ex_lines.append(f"{mesh.name} / {rays.name} / {name}:")
                    ex_lines += e[0].lines(e[1], args.explain, ref_name, name)
        if md:
            ex_lines.append("```")
        out += ex_lines
        out.append("")

    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0
    out.append(f"Peak resident memory of this process: {peak:,.0f} MiB.")
    print("\n".join(out))
    return 0


if __name__ == "__main__":
    sys.exit(main())
