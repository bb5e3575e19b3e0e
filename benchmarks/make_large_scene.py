"""A deterministic Mitsuba 3 scene of a real scene's size, for load/build/render benchmarks.

Modelled on Mitsuba's lego tutorial scene (439 PLY files, 2.0 M triangles, an environment
map, diffuse materials): ``meshes`` binary little-endian PLY files (float32 positions, vertex
normals and uvs, as exporters write them) holding ``triangles`` triangles in total, an
``envmap`` (an .exr sky: a vertical gradient and a sun), ``bsdfs`` diffuse BSDFs defined once
at the top and shared through ``<ref>``, a perspective sensor with an ``independent`` sampler
and the ``direct`` integrator.

Each mesh is a superquadric torus (a rounded ring, closed, no degenerate triangles) of
``nu x nv`` vertices and ``2 nu nv`` triangles, in world coordinates (identity ``to_world``,
as Blender exports bake them), placed on a grid of cells on the ground; mesh sizes follow a
log-normal spread (a few large meshes, many small ones), so the total is ``triangles``
within a few percent.  Everything derives from ``seed``: the same arguments write the same
bytes.

    python benchmarks/make_large_scene.py OUT_FOLDER [--triangles 2e6 --meshes 440 --size 128 --spp 256]

writes ``OUT_FOLDER/scene.xml``, ``OUT_FOLDER/meshes/mesh_NNN.ply`` and ``OUT_FOLDER/sky.exr``.
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

__all__ = ["make_scene", "mesh_sizes"]


def mesh_sizes(triangles: int, meshes: int, rng: np.random.Generator) -> list[tuple[int, int]]:
    """``(nu, nv)`` grid sizes per mesh (``2 nu nv`` triangles each), log-normally spread,
    summing to about ``triangles`` (at least 3 x 3 per mesh)."""
    w = rng.lognormal(0.0, 0.8, meshes)
    share = w / w.sum() * triangles / 2                      # nu * nv per mesh
    nv = np.maximum(3, np.round(np.sqrt(share / 2))).astype(int)
    nu = np.maximum(3, np.round(share / nv)).astype(int)
    return list(zip(nu.tolist(), nv.tolist()))


def _spow(x: np.ndarray, e: float) -> np.ndarray:
    """sign(x) |x|^e (superquadric profiles)."""
    return np.sign(x) * np.abs(x) ** e


def torus_mesh(nu: int, nv: int, center, radius: float, thickness: float, e1: float, e2: float,
               stretch) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """``(vertices, faces, normals, uvs)`` of a superquadric torus, float64/int64: grid
    ``(u, v)`` in [0, 2 pi)^2, x = (R + r c(v)) c(u), z = (R + r c(v)) s(u), y = r s(v) with
    c = sign(cos) |cos|^e; normals from the grid's central differences (a closed surface)."""
    u = np.arange(nu) * (2 * np.pi / nu)
    v = np.arange(nv) * (2 * np.pi / nv)
    U, V = np.meshgrid(u, v, indexing="ij")
    ring = radius + thickness * _spow(np.cos(V), e2)
    p = np.stack([ring * _spow(np.cos(U), e1), thickness * _spow(np.sin(V), e2), ring * _spow(np.sin(U), e1)], -1)
    p = p * np.asarray(stretch) + np.asarray(center)
    du = np.roll(p, -1, 0) - np.roll(p, 1, 0)
    dv = np.roll(p, -1, 1) - np.roll(p, 1, 1)
    n = np.cross(dv, du)
    n /= np.maximum(np.linalg.norm(n, axis=-1, keepdims=True), 1e-30)
    i, j = np.meshgrid(np.arange(nu), np.arange(nv), indexing="ij")
    a = i * nv + j
    b = ((i + 1) % nu) * nv + j
    c = ((i + 1) % nu) * nv + (j + 1) % nv
    d = i * nv + (j + 1) % nv
    faces = np.concatenate([np.stack([a, d, c], -1).reshape(-1, 3), np.stack([a, c, b], -1).reshape(-1, 3)])
    uvs = np.stack([U / (2 * np.pi), V / (2 * np.pi)], -1).reshape(-1, 2)
    return p.reshape(-1, 3), faces, n.reshape(-1, 3), uvs


def _envmap(path: Path, width: int, height: int) -> None:
    """A latitude-longitude sky (.exr, linear): blue gradient above, grey ground, a sun."""
    from vrlab.render.image import save_image

    theta = (np.arange(height) + 0.5) / height * np.pi                 # from +y down
    phi = (np.arange(width) + 0.5) / width * 2 * np.pi
    T, P = np.meshgrid(theta, phi, indexing="ij")
    up = np.cos(T)
    sky = np.where(up[..., None] > 0, np.array([0.35, 0.55, 1.0]) * (0.4 + 0.6 * up[..., None]),
                   np.array([0.25, 0.22, 0.2]))
    sun_dir = np.array([np.sin(0.8) * np.cos(1.0), np.cos(0.8), np.sin(0.8) * np.sin(1.0)])
    w = np.stack([np.sin(T) * np.cos(P), np.cos(T), np.sin(T) * np.sin(P)], -1)
    sun = np.exp((w @ sun_dir - 1.0) / 0.002) * 200.0
    save_image(path, (sky + sun[..., None] * np.array([1.0, 0.9, 0.7])).astype(np.float32))


def make_scene(folder, triangles: int = 2_000_000, meshes: int = 440, *, bsdfs: int = 6, width: int = 128,
               height: int = 128, spp: int = 256, seed: int = 0, env_size: tuple[int, int] = (512, 256)) -> Path:
    """Write the scene into ``folder`` (created); returns the path of ``scene.xml``."""
    from vrlab.render.meshes import MeshData, write_ply

    if not 10 <= meshes <= 100_000:
        raise ValueError(f"meshes must lie in [10, 100000], got {meshes}")
    if not 18 * meshes <= triangles <= 50_000_000:
        raise ValueError(f"triangles must lie in [18 x meshes, 5e7], got {triangles}")
    folder = Path(folder)
    (folder / "meshes").mkdir(parents=True, exist_ok=True)
    rng = np.random.default_rng(seed)
    sizes = mesh_sizes(triangles, meshes, rng)
    side = int(np.ceil(np.sqrt(meshes)))
    colours = rng.uniform(0.15, 0.85, (bsdfs, 3))
    lines = ['<scene version="3.0.0">',
             '    <integrator type="direct"/>',
             '    <sensor type="perspective">',
             '        <float name="fov" value="40"/>',
             f'        <transform name="to_world"><lookat origin="{0.0:g}, {0.9 * side:g}, {-1.25 * side:g}" '
             'target="0, 0, 0" up="0, 1, 0"/></transform>',
             f'        <sampler type="independent"><integer name="sample_count" value="{spp}"/></sampler>',
             f'        <film type="hdrfilm"><integer name="width" value="{width}"/>'
             f'<integer name="height" value="{height}"/></film>',
             '    </sensor>',
             '    <emitter type="envmap"><string name="filename" value="sky.exr"/></emitter>']
    for k, c in enumerate(colours):
        lines.append(f'    <bsdf type="diffuse" id="mat{k}"><rgb name="reflectance" '
                     f'value="{c[0]:.3f}, {c[1]:.3f}, {c[2]:.3f}"/></bsdf>')
    total = 0
    for m, (nu, nv) in enumerate(sizes):
        row, col = divmod(m, side)
        centre = (col - (side - 1) / 2, rng.uniform(0.25, 0.6), row - (side - 1) / 2)
        v, f, n, uv = torus_mesh(nu, nv, centre, rng.uniform(0.22, 0.3), rng.uniform(0.08, 0.14),
                                 rng.uniform(0.2, 1.0), rng.uniform(0.3, 1.0), (1.0, rng.uniform(0.8, 2.5), 1.0))
        total += len(f)
        write_ply(folder / "meshes" / f"mesh_{m:03d}.ply", MeshData(v, f, n, uv))
        lines.append(f'    <shape type="ply"><string name="filename" value="meshes/mesh_{m:03d}.ply"/>'
                     f'<ref id="mat{int(rng.integers(bsdfs))}"/></shape>')
    lines.append("</scene>")
    _envmap(folder / "sky.exr", *env_size)
    path = folder / "scene.xml"
    path.write_text("\n".join(lines) + "\n")
    (folder / "SIZE").write_text(f"{total} triangles in {meshes} meshes\n")
    return path


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("folder")
    ap.add_argument("--triangles", type=float, default=2e6)
    ap.add_argument("--meshes", type=int, default=440)
    ap.add_argument("--size", type=int, default=128)
    ap.add_argument("--spp", type=int, default=256)
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args(argv)
    path = make_scene(args.folder, int(args.triangles), args.meshes, width=args.size, height=args.size,
                      spp=args.spp, seed=args.seed)
    print(f"wrote {path}: {(Path(args.folder) / 'SIZE').read_text().strip()}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
