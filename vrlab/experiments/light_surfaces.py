"""Light-surface sampling: points on box and ellipsoid lights, and the directions they induce.

Questions answered (tables in ``light_surfaces_*.csv``, figures ``*.png``):

* box light (the cube of the built-in ``box_ellipsoid`` scene): a face picked with
  probability area_k / A, then a uniform point on it, is uniform by area (p = 1/A):
  chi-square p-values for the points and for the face counts; picking faces with equal
  probability is rejected;
* ellipsoid light: a uniform unit-sphere point mapped by x = c + M s is *not* uniform by
  area; its density 1 / (4 pi |det M| ||M^-T n_s||) passes chi-square, the two naive
  densities 1/A ("it is uniform") and 1 / (4 pi |det M|) ("the volume factor is enough")
  are rejected;
* area to solid angle, p_w = p_A d^2 / |cos theta_l|, summed over *both* points where the
  ray crosses a closed light: the one-hit density integrates to well below 1 ((1 - r/d)/2
  for a sphere), the two-hit density to 1 (quadrature over the directions);
* irradiance at a floor point under each light: light sampling (both hits), light sampling
  with the one-hit pdf (biased) and cosine sampling, against quadrature over the light's
  surface (the area form of the same integral);
* a small render of ``box_ellipsoid``: cosine vs light vs mixture vs MIS (power) at equal
  spp (``vrlab.render.render`` with those presets; it returns an ``Estimate``), relative
  MSE against a higher-spp reference.

Run ``python -m vrlab.experiments.light_surfaces [--full] [--out DIR]``.
"""
from __future__ import annotations

import time
from pathlib import Path

import numpy as np
import pandas as pd

from vrlab.distributions import (BoxSurface, CosineHemisphere, EllipsoidSurface,
                                 SolidAngleFromArea, SphereSurface, to_world)
from vrlab.render import builtin_scene_path, load_scene, render
from vrlab.render.image import rel_mse
from vrlab.testing import (AtlasChart, CapChart, EllipsoidChart, EllipsoidViewChart, ParallelogramChart,
                           chi2_discrete, chi2_gof, sidak_threshold)
from vrlab.testing.chisquare import cell_integrals, histogram
from vrlab.lab.experiment import experiment_cli, output_dir, save_figure

from . import _light_surfaces_figures as figs

DEFAULT_OUT = Path("vrlab-out") / "light_surfaces"          # relative to the working folder
ALPHA = 0.01        # family-wise level of the chi-square tests of the correct densities
N_CORRECT = 3       # box points, box faces, ellipsoid points
REJECT = 1e-6       # a wrong density must give a p-value below this
FLOOR_NORMAL = np.array([0.0, 1.0, 0.0])
REFS = {"box": np.array([-0.7, 0.0, 0.6]), "ellipsoid": np.array([0.6, 0.0, 0.7])}   # floor points


# --------------------------------------------------------------------------- the two lights
def scene_lights() -> dict:
    """The cube and ellipsoid emitters of ``box_ellipsoid`` as vrlab surfaces (same to_world)."""
    scene = load_scene(builtin_scene_path("box_ellipsoid"))
    shapes = {s.type: s for s in scene.shapes if s.emitter is not None}
    return {"box": BoxSurface.from_matrix(shapes["cube"].to_world),
            "ellipsoid": EllipsoidSurface.from_matrix(shapes["ellipsoid"].to_world)}


def box_faces(box: BoxSurface) -> list[tuple[np.ndarray, np.ndarray, np.ndarray]]:
    """(corner, edge1, edge2) of the six faces of c + L [-1, 1]^3, face k = 2 axis + (side > 0)."""
    c, L = box.center, box.L
    faces = []
    for axis in range(3):
        i, j = [a for a in range(3) if a != axis]
        for sign in (-1.0, 1.0):
            faces.append((c + sign * L[:, axis] - L[:, i] - L[:, j], 2 * L[:, i], 2 * L[:, j]))
    return faces


def box_chart(box: BoxSurface) -> AtlasChart:
    """The six faces as parallelogram charts side by side (chi-square bins face by face)."""
    return AtlasChart([ParallelogramChart(*f) for f in box_faces(box)])


class EqualFaceBox:
    """A common mistake: each face with probability 1/6 (then uniform on it), claiming p = 1/A."""

    dim_u = 2

    def __init__(self, box: BoxSurface):
        self.box = box
        self.faces = box_faces(box)

    def sample(self, u):
        k = np.minimum((6 * u[..., 0]).astype(int), 5)
        s = 6 * u[..., 0] - k
        corner, e1, e2 = (np.array([f[m] for f in self.faces])[k] for m in range(3))
        return corner + s[..., None] * e1 + u[..., 1:2] * e2

    def pdf(self, x):
        return np.full(np.shape(x)[:-1], 1.0 / self.box.area)


class ClaimedDensity:
    """The ellipsoid's own sampler with a different (wrong) claimed area density."""

    dim_u = 2

    def __init__(self, surface, pdf):
        self.surface, self._pdf = surface, pdf

    def sample(self, u):
        return self.surface.sample(u)

    def pdf(self, x):
        return self._pdf(x)


# --------------------------------------------------------------------------- 1-2: area sampling
def area_gof(lights: dict, n: int, seed: int = 0) -> pd.DataFrame:
    box, ell = lights["box"], lights["ellipsoid"]
    level = sidak_threshold(ALPHA, N_CORRECT)
    echart = EllipsoidChart(ell.center, ell.M)
    u = np.random.default_rng(seed).random((n, 2))
    faces = box.face(box.sample(u))
    naive = 1.0 / (4 * np.pi * ell.abs_det)
    cases = [
        ("box", "faces by area, uniform on face (p = 1/A)", True,
         chi2_gof(box, box_chart(box), (36, 12), n=n, rng=seed + 1)),
        ("box", "face index ~ area_k / A (discrete)", True, chi2_discrete(faces, box.face_probs)),
        ("box", "faces with equal probability 1/6, claimed p = 1/A", False,
         chi2_gof(EqualFaceBox(box), box_chart(box), (36, 12), n=n, rng=seed + 2)),
        ("ellipsoid", "p = 1/(4π|det M| ‖M⁻ᵀn_s‖) (Jacobian)", True,
         chi2_gof(ell, echart, (20, 20), n=n, rng=seed + 3)),
        ("ellipsoid", "claimed uniform, p = 1/A", False,
         chi2_gof(ClaimedDensity(ell, lambda x: np.full(np.shape(x)[:-1], 1 / ell.area)), echart, (20, 20),
                  n=n, rng=seed + 3)),
        ("ellipsoid", "claimed p = 1/(4π|det M|) (no ‖M⁻ᵀn_s‖)", False,
         chi2_gof(ClaimedDensity(ell, lambda x: np.full(np.shape(x)[:-1], naive)), echart, (20, 20),
                  n=n, rng=seed + 3)),
    ]
    rows = [{"light": light, "density": label, "correct": ok, "chi2": r.statistic, "dof": r.dof,
             "pvalue": r.pvalue, "n": r.n, "level": level if ok else REJECT,
             "passes": (r.pvalue > level) if ok else (r.pvalue < REJECT)}
            for light, label, ok, r in cases]
    return pd.DataFrame(rows)


def area_sample_data(lights: dict, n: int = 4000, n_map: int = 200_000, seed: int = 4) -> dict:
    """What ``area_samples_figure`` draws: ``n`` box and ellipsoid points (box faces,
    A p_A of the ellipsoid points) and, from ``n_map`` ellipsoid points, observed / expected
    counts per chart cell under the Jacobian pdf and under the 'uniform' pdf 1/A."""
    box, ell = lights["box"], lights["ellipsoid"]
    u = np.random.default_rng(seed).random((n, 2))
    x, y = box.sample(u), ell.sample(u)
    chart, bins = EllipsoidChart(ell.center, ell.M), (20, 20)
    counts, _ = histogram(chart.to_param(ell.sample(np.random.default_rng(seed + 1).random((n_map, 2)))), bins)
    uniform = lambda x: np.full(np.shape(x)[:-1], 1 / ell.area)     # noqa: E731
    return {"box_points": x, "box_faces": box.face(x), "ell_points": y, "ell_area_pdf": ell.area * ell.pdf(y),
            "ratio": {k: counts / (n_map * cell_integrals(pdf, chart, bins))
                      for k, pdf in (("Jacobian", ell.pdf), ("uniform", uniform))}}


# --------------------------------------------------------------------------- 3: area -> solid angle
class FirstHitOnly:
    """A surface that reports only the nearest crossing of a ray: the one-hit pdf (a bug)."""

    def __init__(self, surface):
        self.s = surface
        self.dim_u = surface.dim_u

    def __getattr__(self, name):
        return getattr(self.s, name)

    def intersect(self, origin, direction, t_min=None):
        return self.s.intersect(origin, direction, t_min)[..., :1]


def in_frame(pdf, axis):
    """A direction density viewed in the frame whose +z is ``axis`` (for an aimed cap chart)."""
    return lambda w: pdf(to_world(w, axis))


def aimed_cap(surface, ref, margin: float = 1.01):
    """Axis towards the bounding sphere and a cap z >= z_min (in that frame) containing it."""
    c, r = surface.bounding_sphere()
    v = c - ref
    d = np.linalg.norm(v)
    return v / d, 1.0 - (1.0 - np.sqrt(1.0 - (r / d) ** 2)) * margin


def direction_mass(surface, ref, pdf, m: int) -> float:
    """int pdf(w) dw over the directions that can hit ``surface`` from ``ref``."""
    if isinstance(surface, SphereSurface):
        surface = EllipsoidSurface(surface.center, surface.radius * np.eye(3))
    if isinstance(surface, EllipsoidSurface):
        return float(cell_integrals(pdf, EllipsoidViewChart(surface.center, surface.M, ref), (32, 32), 8).sum())
    axis, z_min = aimed_cap(surface, ref)       # box: jumps at the outline, refined quadrature
    return float(cell_integrals(in_frame(pdf, axis), CapChart(z_min, 1), (m, m), 4, sub=2).sum())


def normalisation_table(lights: dict, m: int) -> pd.DataFrame:
    sphere_ref = np.array([0.0, 0.0, 0.5])
    sphere = SphereSurface([0.0, 1.0, 0.0], 0.5)
    cases = {"sphere r=0.5": (sphere, sphere_ref), "box": (lights["box"], REFS["box"]),
             "ellipsoid": (lights["ellipsoid"], REFS["ellipsoid"])}
    rows = []
    for name, (surf, ref) in cases.items():
        both = SolidAngleFromArea(surf, ref)
        one = SolidAngleFromArea(FirstHitOnly(surf), ref)
        row = {"light": name, "distance_to_center": float(np.linalg.norm(surf.bounding_sphere()[0] - ref)),
               "mass_first_hit_only": direction_mass(surf, ref, one.pdf, m),
               "mass_both_hits": direction_mass(surf, ref, both.pdf, m)}
        if name.startswith("sphere"):
            d = np.linalg.norm(sphere.center - ref)
            row["theory_first_hit"] = 0.5 * (1 - sphere.radius / d)
        rows.append(row)
    return pd.DataFrame(rows)


def direction_pdf_maps(lights: dict, m: int = 160) -> dict:
    """p_w on a square window of the tangent plane of an aimed cap around each light, as
    seen from its floor point: {light: (first hit, second hit, both hits, half width R)}."""
    out = {}
    for name in ("box", "ellipsoid"):
        surf, ref = lights[name], REFS[name]
        axis, z_min = aimed_cap(surf, ref, margin=1.15)
        g = (np.arange(m) + 0.5) / m
        s = np.stack(np.meshgrid(g, g, indexing="ij"), -1)
        R = np.sqrt(1 - z_min**2)
        xy = (2 * s - 1) * R
        local = np.concatenate([xy, np.sqrt(np.clip(1 - np.sum(xy**2, -1, keepdims=True), 0, None))], -1)
        w = to_world(local, axis)
        both = SolidAngleFromArea(surf, ref).pdf(w)
        first = SolidAngleFromArea(FirstHitOnly(surf), ref).pdf(w)
        out[name] = (first, both - first, both, R)
    return out


# --------------------------------------------------------------------------- 4: irradiance
def irradiance_area_form(surface, ref, n_ref, bins: int) -> float:
    """E = int_visible cos(theta_r) cos(theta_l) / d^2 dA (unit radiance), Gauss on surface charts.

    For a convex light seen from outside, the visible part is where the outward normal faces
    ``ref``; on a box that is whole faces (smooth integrand), on an ellipsoid it ends at the
    silhouette, where cos(theta_l) -> 0 (a kink, so the error is estimated by halving bins).
    """
    def g(y):
        v = ref - y
        d2 = np.sum(v * v, -1)
        d = np.sqrt(d2)
        cos_l = np.sum(surface.normal(y) * v, -1) / d
        cos_r = -(v @ n_ref) / d
        return np.clip(cos_l, 0, None) * np.clip(cos_r, 0, None) / d2

    if isinstance(surface, BoxSurface):
        return float(sum(cell_integrals(g, ParallelogramChart(*f), (bins, bins), 6).sum() for f in box_faces(surface)))
    return float(cell_integrals(g, EllipsoidChart(surface.center, surface.M), (bins, bins), 6).sum())


def irradiance_table(lights: dict, n: int, seed: int = 6) -> pd.DataFrame:
    rows = []
    for k, (name, surf) in enumerate(lights.items()):
        ref, n_ref = REFS[name], FLOOR_NORMAL
        bins = 16 if isinstance(surf, BoxSurface) else 128     # box faces: smooth, Gauss converges at once
        fine = irradiance_area_form(surf, ref, n_ref, bins)
        qerr = abs(fine - irradiance_area_form(surf, ref, n_ref, bins // 2))
        u = np.random.default_rng([seed, k]).random((n, 2))
        ests = {}
        for label, d in [("light sampling, both hits", SolidAngleFromArea(surf, ref)),
                         ("light sampling, first hit only", SolidAngleFromArea(FirstHitOnly(surf), ref))]:
            w, p = d.sample_pdf(u)
            ests[label] = np.clip(w @ n_ref, 0, None) / p
        w = to_world(CosineHemisphere().sample(u), n_ref)       # p = cos/pi: f/p = pi * [ray hits the light]
        ests["cosine sampling"] = np.pi * np.isfinite(surf.intersect(ref, w)[..., 0])
        for label, f in ests.items():
            est, se = float(f.mean()), float(f.std(ddof=1) / np.sqrt(n))
            rows.append({"light": name, "estimator": label, "n": n, "estimate": est, "stderr": se,
                         "quadrature": fine, "quad_error": qerr, "z": (est - fine) / se,
                         "var_per_sample": float(f.var(ddof=1)), "unbiased": "first hit" not in label})
    return pd.DataFrame(rows)


# --------------------------------------------------------------------------- 5: render
RENDER_STRATEGIES = ("cosine", "light", "mixture", "mis-power")


def render_study(size: tuple[int, int], spp: int, ref_spp: int, seed: int = 7):
    scene = load_scene(builtin_scene_path("box_ellipsoid"))
    scene = scene.with_size(size[0], size[1])
    t0 = time.perf_counter()
    reference = render(scene, ref_spp, "mis-power", rng=np.random.SeedSequence([seed, 1])).value
    ref_secs = time.perf_counter() - t0
    images, rows = {}, []
    for s in RENDER_STRATEGIES:
        t0 = time.perf_counter()
        est = render(scene, spp, s, rng=np.random.SeedSequence([seed, 0]))
        img, err = est.value, est.stderr
        secs = time.perf_counter() - t0
        images[s] = img
        rows.append({"strategy": s, "spp": spp, "rel_mse": rel_mse(img, reference),
                     "mean_pixel_stderr": float(np.nanmean(err)), "image_mean": float(img.mean()),
                     "seconds": secs})
    rows.append({"strategy": "reference (mis-power)", "spp": ref_spp, "rel_mse": 0.0,
                 "mean_pixel_stderr": np.nan, "image_mean": float(reference.mean()), "seconds": ref_secs})
    table = pd.DataFrame(rows)
    cos = table.set_index("strategy").loc["cosine", "rel_mse"]
    table["rel_mse_vs_cosine"] = table["rel_mse"] / cos
    return table, images, reference


def gallery_numbers(out: str | Path) -> dict:
    """The gallery caption's numbers, from ``light_surfaces_normalisation.csv``."""
    n = pd.read_csv(Path(out) / "light_surfaces_normalisation.csv").set_index("light")
    return {f"first_{k}": f"{n.loc[k, 'mass_first_hit_only']:.2f}" for k in ("box", "ellipsoid")} | {
        "both_max_error": f"{(n['mass_both_hits'] - 1).abs().max():.0e}"}


def main(out: str | Path = DEFAULT_OUT, full: bool = False) -> dict:
    """Run every experiment, write CSV + PNG into ``out``, return the key numbers."""
    out = output_dir(out)
    lights = scene_lights()
    gof = area_gof(lights, 1_000_000 if full else 200_000)
    gof.to_csv(out / "light_surfaces_gof.csv", index=False)
    save_figure(figs.area_samples_figure(area_sample_data(lights), gof), out / "light_surfaces_area_samples.png")
    norm = normalisation_table(lights, 256 if full else 64)
    norm.to_csv(out / "light_surfaces_normalisation.csv", index=False)
    save_figure(figs.direction_pdfs_figure(direction_pdf_maps(lights), norm), out / "light_surfaces_direction_pdfs.png")
    irr = irradiance_table(lights, 1_000_000 if full else 100_000)
    irr.to_csv(out / "light_surfaces_irradiance.csv", index=False)
    size, spp, ref_spp = ((128, 96), 16, 512) if full else ((64, 48), 8, 96)
    renders, images, reference = render_study(size, spp, ref_spp)
    renders.to_csv(out / "light_surfaces_renders.csv", index=False)
    save_figure(figs.renders_figure(images, reference, renders), out / "light_surfaces_renders.png")
    return {
        "gof": gof, "normalisation": norm, "irradiance": irr, "renders": renders,
        "level": sidak_threshold(ALPHA, N_CORRECT),
        "files": sorted(p.name for p in out.iterdir()),
    }


if __name__ == "__main__":
    experiment_cli(main, DEFAULT_OUT, __doc__)
