"""A batch of 1e7 rays adds at most its output arrays to the process's peak memory, and
a fixed allowance for the chunk buffers (2^18 rays of rays and hits, 20 MiB in float)."""

import subprocess
import sys

CODE = r"""
import numpy as np, twinray

def status(key):  # kB, from /proc/self/status
    for line in open("/proc/self/status"):
        if line.startswith(key + ":"):
            return int(line.split()[1])

scene = twinray.Scene()
scene.add_sphere((0, 0, 0), 1)
scene.add_plane((0, -1, 0), (0, 1, 0))
tracer = twinray.Tracer(scene, backend="cpu")
n = 10_000_000
rng = np.random.default_rng(1)
o = rng.uniform(-2, 2, (n, 3)).astype(np.float32)
d = rng.normal(size=(n, 3)).astype(np.float32)
tracer.intersect(o[:1000], d[:1000])   # the backend's own one-off allocations
# Linux resets the peak (VmHWM) to the current resident size on "5" (proc(5), clear_refs),
# so the peak below is this call's, not the random numbers' made before it.
with open("/proc/self/clear_refs", "w") as f:
    f.write("5")
before = status("VmRSS")
hits = tracer.intersect(o, d)
after = status("VmHWM")
outputs = sum(a.nbytes for a in (hits.t, hits.u, hits.v, hits.normal, hits.object, hits.primitive,
                                  hits.instance))
print(before, after, outputs // 1024, int((hits.object >= 0).sum()))
"""


def test_ten_million_rays_add_only_their_outputs():
    out = subprocess.run([sys.executable, "-c", CODE], capture_output=True, text=True,
                         check=True).stdout.split()
    before_kib, after_kib, outputs_kib, hit = map(int, out)
    allowance_kib = 32 * 1024
    assert hit > 1_000_000
    assert after_kib - before_kib <= outputs_kib + allowance_kib, (before_kib, after_kib,
                                                                   outputs_kib)
