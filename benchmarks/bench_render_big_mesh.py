"""A render of a large mesh with 1 and 2 local worker processes (issue 35): does each worker
receive the scene once?  Wall time of the whole ``render`` call and peak memory (``ru_maxrss``)
of the parent and of the largest worker, each mode in a fresh ``python -c`` process.

The scene: a height field of ``--grid``^2 vertices with random heights (2 (grid - 1)^2
triangles, none coplanar with its neighbour, so none merges into a parallelogram; grid = 708:
about 1 M triangles), written as a binary PLY, under a rectangular light, rendered at a small
resolution so that the geometry, not the pixels, dominates.

    python benchmarks/bench_render_big_mesh.py [--grid 708 --size 128 --spp 16 --rounds 1 --dask]

Forked local workers' peak RSS counts the pages they share with the parent.
"""
from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]

SCENE = """<scene version="3.0.0">
    <integrator type="direct"/>
    <sensor type="perspective">
        <float name="fov" value="50"/>
        <transform name="to_world"><lookat origin="0, -2.2, 1.6" target="0, 0, 0" up="0, 0, 1"/></transform>
        <sampler type="independent"><integer name="sample_count" value="4"/></sampler>
        <film type="hdrfilm"><integer name="width" value="64"/><integer name="height" value="64"/></film>
    </sensor>
    <bsdf type="diffuse" id="white"><rgb name="reflectance" value="0.7, 0.7, 0.7"/></bsdf>
    <shape type="ply"><string name="filename" value="terrain.ply"/><ref id="white"/></shape>
    <shape type="rectangle">
        <transform name="to_world"><scale value="0.3"/><rotate x="1" angle="180"/><translate z="1.5"/></transform>
        <emitter type="area"><rgb name="radiance" value="20, 20, 20"/></emitter>
    </shape>
</scene>
"""

CHILD = """
import json, resource, sys, time
sys.path.insert(0, {root!r})
from vrlab.render import keep_freed_memory, load_scene, render
keep_freed_memory()
spec = json.loads({spec!r})
scene = load_scene(spec["scene"])
client = None
if spec["dask"]:
    from distributed import Client, LocalCluster
    cluster = LocalCluster(n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1",
                           dashboard_address=None)
    client = Client(cluster)
    client.run(keep_freed_memory)
t = time.perf_counter()
img = render(scene, spec["spp"], rng=1, width=spec["size"], height=spec["size"] * 3 // 4, workers=spec["workers"],
             executor=client)
wall = time.perf_counter() - t
import numpy as np
np.save(spec["out"], img.value)
out = {{"wall": wall, "parent_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024,
        "worker_mb": resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024}}
if client is not None:
    rss = client.run(lambda: __import__("resource").getrusage(__import__("resource").RUSAGE_SELF).ru_maxrss)
    out["worker_mb"] = max(rss.values()) / 1024
    client.close()
    cluster.close()
print(json.dumps(out))
"""


def write_scene(folder: Path, grid: int) -> tuple[Path, int]:
    """The PLY height field and the scene XML in ``folder``: (XML path, triangles)."""
    rng = np.random.default_rng(0)
    x, y = np.meshgrid(np.linspace(-1, 1, grid), np.linspace(-1, 1, grid), indexing="ij")
    z = 0.02 * rng.standard_normal(x.shape)
    v = np.stack([x, y, z], -1).reshape(-1, 3).astype("<f4")
    i = np.arange(grid * grid).reshape(grid, grid)[:-1, :-1].ravel()
    tri = np.concatenate([np.stack([i, i + grid, i + grid + 1], 1), np.stack([i, i + grid + 1, i + 1], 1)])
    faces = np.empty(len(tri), dtype=[("n", "u1"), ("v", "<i4", 3)])
    faces["n"], faces["v"] = 3, tri
    head = (f"ply\nformat binary_little_endian 1.0\nelement vertex {len(v)}\nproperty float x\nproperty float y\n"
            f"property float z\nelement face {len(tri)}\nproperty list uchar int vertex_indices\nend_header\n")
    with open(folder / "terrain.ply", "wb") as f:
        f.write(head.encode())
        f.write(v.tobytes())
        f.write(faces.tobytes())
    (folder / "scene.xml").write_text(SCENE)
    return folder / "scene.xml", len(tri)


def run(scene: Path, workers: int, size: int, spp: int, out: Path, dask: bool = False) -> dict:
    spec = json.dumps({"scene": str(scene), "workers": workers, "size": size, "spp": spp, "out": str(out),
                       "dask": dask})
    res = subprocess.run([sys.executable, "-c", CHILD.format(root=str(ROOT), spec=spec)], capture_output=True,
                         text=True, cwd=ROOT)
    if res.returncode:
        raise RuntimeError(res.stderr[-2000:])
    return json.loads(res.stdout.strip().splitlines()[-1])


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--grid", type=int, default=708)
    ap.add_argument("--size", type=int, default=128)
    ap.add_argument("--spp", type=int, default=16)
    ap.add_argument("--rounds", type=int, default=1)
    ap.add_argument("--dask", action="store_true", help="also on a Dask LocalCluster of 2 workers")
    args = ap.parse_args(argv)
    modes = [("1", 1, False), ("2", 2, False)] + ([("Dask LocalCluster (2)", 2, True)] if args.dask else [])
    with tempfile.TemporaryDirectory() as d:
        scene, n_tri = write_scene(Path(d), args.grid)
        rows = {}
        for _ in range(args.rounds):
            for k, (name, w, dask) in enumerate(modes):
                r = run(scene, w, args.size, args.spp, Path(d) / f"m{k}.npy", dask)
                if name not in rows or r["wall"] < rows[name]["wall"]:
                    rows[name] = r
        first = np.load(Path(d) / "m0.npy")
        same = all(np.array_equal(first, np.load(Path(d) / f"m{k}.npy")) for k in range(1, len(modes)))
    print(f"{n_tri} triangles, {args.size}x{args.size * 3 // 4}, {args.spp} spp, mis-power, best of {args.rounds}; "
          f"load average at the end {os.getloadavg()[0]:.1f} on {os.cpu_count()} CPUs")
    print("| workers | seconds | parent peak RSS MB | largest worker peak RSS MB |")
    print("|---|---|---|---|")
    for w, r in rows.items():
        print(f"| {w} | {r['wall']:.2f} | {r['parent_mb']:.0f} | {r['worker_mb']:.0f} |")
    print(f"images identical: {same}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
