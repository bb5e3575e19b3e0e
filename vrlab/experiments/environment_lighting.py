"""Environment-map lighting: BSDF sampling, light sampling of the map and MIS; delta lights.

An ``envmap`` is radiance L(w) arriving from infinitely far away in every direction, read from
a latitude-longitude image.  Direct lighting at a surface point is L_o = int f_r L(w) V cos dw,
and the techniques are those of any light (the CT5202 MIS slides, "Applications": sample the
BSDF or sample the light; lecture 4 of the Russian course, "Multiple importance sampling"):

* ``bsdf``: w ~ the BSDF's sampling density (cosine-weighted on a diffuse surface);
* ``light``, uniform map: w uniform on the sphere, p = 1 / (4 pi) (vrlab's
  ``<string name="sampling" value="uniform"/>``);
* ``light``, luminance map: w ~ luminance x sin(theta) over the image's cells,
  p_w = p_uv / (2 pi^2 sin theta) (Mitsuba 3 convention, src/emitters/envmap.cpp;
  :class:`vrlab.distributions.EnvironmentMap`);
* MIS of light (luminance) and BSDF, one sample of each: ``mis-balance``, ``mis-power`` and
  the optimal weights of Kondapaneni et al. (2019), ``MIS(["light", "bsdf"],
  heuristic="optimal")``.  Its estimator F_o = sum_k a_k + (1/N) sum (f - a.p)/q is the
  balance estimator with the densities p_k / q as control variates of known mean 1; the
  renderer fits a per pixel by least squares over the pixel's units (consistent, O(1/spp)
  bias; :meth:`vrlab.estimators.MIS.unit_outputs`).

Questions answered (tables ``environment_lighting_*.csv``, figures ``*.png``):

* a diffuse and a glossy sphere on a floor under a sky with a small bright sun (the map is
  written by the experiment, ``environment_lighting_sky.exr``, with the scene files): relMSE
  of each method at equal spp and two evaluations per camera ray, against a high-spp
  ``mis-power`` reference, over all surface pixels and per object;
* a closed form: a diffuse plane of albedo rho under a ``constant`` environment L, unoccluded
  and facing up, reflects L_o = int (rho/pi) L cos dw = rho L exactly: every estimator's
  image mean within 4 standard errors (BSDF sampling and optimal MIS have zero
  variance here: f = rho L p_bsdf);
* delta lights: with a ``point`` light added, ``bsdf`` is refused (no direction sample can
  reach it), while MIS gives the light sample weight 1 there and stays unbiased (image mean
  compared with ``light``).

Run ``python -m vrlab.experiments.environment_lighting [--full] [--out DIR]``.
"""
from __future__ import annotations

import time
from pathlib import Path
from xml.sax.saxutils import quoteattr

import matplotlib.pyplot as plt
from matplotlib.patches import Patch
import numpy as np
import pandas as pd

from vrlab import checks
from vrlab.distributions import EnvironmentMap
from vrlab.distributions.envmap import latlong_direction
from vrlab.estimators import MIS
from vrlab.lab.experiment import experiment_cli, output_dir, save_figure
from vrlab.metrics import image_mean as metrics_image_mean
from vrlab.metrics import rel_mse, relative_squared_error
from vrlab.render import load_scene, render
from vrlab.render.direct import DirectLighting
from vrlab.render.emitters.envmap import read_environment
from vrlab.render.image import save_image

from ._figures import EXPOSURE_NOTE, display, exposure_of, show_image

DEFAULT_OUT = Path("vrlab-out") / "environment_lighting"     # relative to the working folder
SUN = {"elevation": 40.0, "azimuth": 60.0, "radius": 2.0, "radiance": (2500.0, 2325.0, 2050.0)}  # degrees
MAP_SIZE = (128, 256)                  # (H, W) of the lat-long image
REGIONS = {"floor": 0, "diffuse sphere": 1, "glossy sphere": 2}     # shape index in the scene
RHO, L_CONST = (0.7, 0.5, 0.3), (0.8, 1.0, 1.25)                 # the closed-form check
OPTIMAL = "mis-optimal"
COLOURS = {"bsdf": "C1", "light, uniform map": "C7", "light, luminance map": "C0", "mis-balance": "C2",
           "mis-power": "C3", OPTIMAL: "C4"}


def sky_image(height: int = MAP_SIZE[0], width: int = MAP_SIZE[1], sun: dict = SUN) -> np.ndarray:
    """Linear RGB ``(H, W, 3)`` lat-long sky: texel (j, i) looks along ``latlong_direction(((i +
    1/2) / W, j / (H - 1)))`` (Mitsuba 3's envmap lookup, +y up).  Above the horizon
    L = y (0.2, 0.4, 0.9) + (1 - y)(0.85, 0.9, 1.0) (zenith blue to a pale horizon), below it a
    dark ground (0.18, 0.15, 0.12); texels within ``sun["radius"]`` degrees of the sun's
    direction (``elevation``, ``azimuth`` in degrees; azimuth 0 = -z, 90 = +x) take its radiance."""
    height, width = checks.integer(height, "height", low=3), checks.integer(width, "width", low=2)
    towards = sun_direction(sun)
    j, i = np.meshgrid(np.arange(height), np.arange(width), indexing="ij")
    d = latlong_direction(np.stack([(i + 0.5) / width, j / (height - 1)], -1))
    y = d[..., 1:2]
    img = np.where(y >= 0, y * [0.2, 0.4, 0.9] + (1 - y) * [0.85, 0.9, 1.0], [0.18, 0.15, 0.12])
    img[d @ towards >= np.cos(np.radians(sun["radius"]))] = sun["radiance"]
    return img


def sun_direction(sun: dict = SUN) -> np.ndarray:
    """Unit direction to the sun's centre: theta = 90 deg - elevation from +y, u = azimuth / 360."""
    if not isinstance(sun, dict) or not {"elevation", "azimuth", "radius", "radiance"} <= set(sun):
        raise TypeError(f"sun: expected a dict with elevation, azimuth, radius (degrees) and radiance, got {sun!r}")
    checks.real(sun["elevation"], "sun['elevation']", low=-90.0, high=90.0)
    checks.real(sun["radius"], "sun['radius']", low=0.0, high=90.0, low_open=True)
    return latlong_direction([sun["azimuth"] / 360.0, (90.0 - sun["elevation"]) / 180.0])


SCENE = """<scene version="3.0.0">
    <default name="spp" value="16"/>
    <default name="sampling" value="luminance"/>
    <integrator type="direct"/>
    <sensor type="perspective">
        <float name="fov" value="40"/>
        <transform name="to_world"><lookat origin="0, 1.6, 6" target="0, 0.7, 0" up="0, 1, 0"/></transform>
        <sampler type="independent"><integer name="sample_count" value="$spp"/></sampler>
        <film type="hdrfilm"><integer name="width" value="{w}"/><integer name="height" value="{h}"/>
            <rfilter type="box"/></film>
    </sensor>
    <emitter type="envmap">
        <string name="filename" value={sky}/>
        <string name="sampling" value="$sampling"/>
    </emitter>{extra}
    <shape type="rectangle">
        <transform name="to_world"><scale value="8"/><rotate x="1" y="0" z="0" angle="-90"/></transform>
        <bsdf type="diffuse"><rgb name="reflectance" value="0.5"/></bsdf>
    </shape>
    <shape type="sphere">
        <point name="center" x="-1.1" y="0.9" z="0"/><float name="radius" value="0.9"/>
        <bsdf type="diffuse"><rgb name="reflectance" value="0.7, 0.25, 0.2"/></bsdf>
    </shape>
    <shape type="sphere">
        <point name="center" x="1.1" y="0.9" z="0"/><float name="radius" value="0.9"/>
        <bsdf type="roughconductor"><string name="distribution" value="ggx"/><float name="alpha" value="0.08"/>
            <rgb name="specular_reflectance" value="0.95, 0.78, 0.45"/></bsdf>
    </shape>
</scene>
"""
POINT = """
    <emitter type="point">
        <point name="position" x="0" y="2.8" z="1.8"/><rgb name="intensity" value="6, 9, 14"/>
    </emitter>"""
CONSTANT = """<scene version="3.0.0">
    <integrator type="direct"/>
    <sensor type="perspective">
        <float name="fov" value="60"/>
        <transform name="to_world"><lookat origin="0, 1, 0" target="0, 0, 0" up="0, 0, -1"/></transform>
        <film type="hdrfilm"><integer name="width" value="{n}"/><integer name="height" value="{n}"/>
            <rfilter type="box"/></film>
    </sensor>
    <emitter type="constant"><rgb name="radiance" value="{L}"/></emitter>
    <shape type="rectangle">
        <transform name="to_world"><scale value="1000"/><rotate x="1" y="0" z="0" angle="-90"/></transform>
        <bsdf type="diffuse"><rgb name="reflectance" value="{rho}"/></bsdf>
    </shape>
</scene>
"""


def write_scenes(out: Path, size: tuple[int, int]) -> dict:
    """Write the sky (EXR) and the scene files (without and with the point light) into ``out``."""
    sky = save_image(out / "environment_lighting_sky.exr", sky_image())
    paths = {"sky": sky}
    for key, extra in (("scene", ""), ("point", POINT)):
        paths[key] = out / f"environment_lighting_{key}.xml"
        paths[key].write_text(SCENE.format(w=size[0], h=size[1], sky=quoteattr(sky.name), extra=extra))
    return paths


def optimal_mis() -> MIS:
    """Optimal MIS of one light and one BSDF sample per unit (a fitted per pixel)."""
    return MIS(["light", "bsdf"], heuristic="optimal")


def methods() -> list[tuple[str, str, object, dict]]:
    """(label, map sampling, estimator, render keywords): two evaluations per camera ray each."""
    return [("bsdf", "luminance", "bsdf", {"bsdf_samples": 2}),
            ("light, uniform map", "uniform", "light", {"emitter_samples": 2}),
            ("light, luminance map", "luminance", "light", {"emitter_samples": 2}),
            ("mis-balance", "luminance", "mis-balance", {}),
            ("mis-power", "luminance", "mis-power", {}),
            (OPTIMAL, "luminance", optimal_mis(), {})]


def regions(scene, sub: int = 4) -> np.ndarray:
    """(H, W) index of the shape that all ``sub`` x ``sub`` camera rays of the pixel hit, -1 where
    they hit several shapes or the sky (an object's edge)."""
    s = DirectLighting(scene).pixel_hits(sub)
    h, w = scene.sensor.height, scene.sensor.width
    return np.where((s == s[:, :1]).all(-1), s[:, 0], -1).reshape(h, w)


def image_mean(est) -> tuple[np.ndarray, np.ndarray]:
    """Per-channel mean over the pixels and its standard error (:func:`vrlab.metrics.image_mean`)."""
    return metrics_image_mean(est.value, est.stderr)


def compare(paths: dict, spp: int, ref_spp: int, seed: int = 11) -> tuple[pd.DataFrame, dict, np.ndarray]:
    """Render the scene with every method at ``spp`` and a ``mis-power`` reference at ``ref_spp``;
    relMSE (reference variance subtracted) over the surface pixels and per region."""
    scenes = {s: load_scene(paths["scene"], {"sampling": s}) for s in ("luminance", "uniform")}
    reg = regions(scenes["luminance"])
    t0 = time.perf_counter()
    r = render(scenes["luminance"], ref_spp, "mis-power", rng=[seed, 0])
    ref_sec = time.perf_counter() - t0
    ref, ref_err = r.value.astype(float), r.stderr.astype(float)
    rows, images = [], {}
    for k, (label, sampling, est, kw) in enumerate(methods(), start=1):
        t0 = time.perf_counter()
        e = render(scenes[sampling], spp, est, rng=[seed, k], **kw)
        sec = time.perf_counter() - t0
        images[label] = e.value
        row = {"method": label, "map_sampling": sampling, "estimator": e.method, "spp": spp,
               "evals_per_ray": 2, "seconds": sec, "relmse": rel_mse(e.value, ref, ref_err=ref_err, mask=reg >= 0)}
        for name, i in REGIONS.items():
            row[f"relmse {name}"] = rel_mse(e.value, ref, ref_err=ref_err, mask=reg == i)
        row["relmse_from_stderr"] = float(np.mean(relative_squared_error(e.stderr.astype(float) ** 2, ref)[reg >= 0]))
        row.update(mean=float(e.value.mean()), ref_mean=float(ref.mean()))
        rows.append(row)
    t = pd.DataFrame(rows)
    t["pixels"] = int((reg >= 0).sum())
    t.attrs.update(ref_spp=ref_spp, ref_seconds=ref_sec)
    return t, images, ref


def sun_fractions(env: EnvironmentMap, n: int = 200_000, seed: int = 5) -> dict:
    """Probability that a light sample of ``env`` lands within 1.5 radii of the centre of the sun
    ``SUN``: luminance sampling (measured on n samples) against uniform sampling ((1 - cos r) / 2,
    the cap's solid angle 2 pi (1 - cos r) over 4 pi; exact)."""
    cone = np.cos(np.radians(1.5 * SUN["radius"]))
    w = env.sample(np.random.default_rng(seed).random((n, 2)))
    return {"luminance": float(np.mean(w @ sun_direction() >= cone)), "uniform": (1.0 - cone) / 2.0, "n": n}


def constant_check(n: int, spp: int, seed: int = 21) -> pd.DataFrame:
    """Image mean of the plane under the constant environment against rho L, per channel."""
    scene = load_scene(CONSTANT.format(n=n, L=", ".join(map(str, L_CONST)), rho=", ".join(map(str, RHO))))
    exact = np.multiply(RHO, L_CONST)
    rows = []
    for k, (label, est, kw) in enumerate((("bsdf", "bsdf", {}), ("light", "light", {}), ("mis-balance", "mis-balance", {}),
                                          ("mis-power", "mis-power", {}), (OPTIMAL, optimal_mis(), {}))):
        mean, se = image_mean(render(scene, spp, est, rng=[seed, k], **kw))
        rows += [{"method": label, "channel": c, "spp": spp, "mean": mean[i], "stderr": se[i], "exact": exact[i]}
                 for i, c in enumerate("RGB")]
    t = pd.DataFrame(rows)
    t["error"] = t["mean"] - t["exact"]
    t["zero_variance"] = t["stderr"] <= 1e-6 * t["exact"]          # up to float32 rounding
    t["z"] = np.where(t["zero_variance"], np.nan, t["error"] / t["stderr"].where(~t["zero_variance"], 1.0))
    # 4 standard errors, plus float32 rounding of the pixel values (the zero-variance estimators)
    t["ok"] = np.abs(t["error"]) <= 4 * t["stderr"] + 1e-5 * t["exact"]
    return t


def delta_check(paths: dict, spp: int, seed: int = 31) -> tuple[pd.DataFrame, str, dict]:
    """With the point light: the refusal of ``bsdf`` (its message) and the image means of light
    sampling and MIS, with the z-score of each against ``light``."""
    scene = load_scene(paths["point"])
    try:
        render(scene, 1, "bsdf", width=4, height=3)
        refusal = ""
    except ValueError as exc:
        refusal = str(exc)
    rows, images = [], {}
    for k, (label, kw) in enumerate((("light", {"emitter_samples": 2}), ("mis-balance", {}), ("mis-power", {}))):
        e = render(scene, spp, label, rng=[seed, k], **kw)
        mean, se = image_mean(e)
        images[label] = e.value
        rows += [{"method": label, "spp": spp, "channel": c, "mean": mean[i], "stderr": se[i]} for i, c in enumerate("RGB")]
    t = pd.DataFrame(rows)
    light = t[t["method"] == "light"].set_index("channel")
    t["z_vs_light"] = [0.0 if m == "light" else (v - light.loc[c, "mean"]) / np.hypot(s, light.loc[c, "stderr"])
                       for m, c, v, s in zip(t["method"], t["channel"], t["mean"], t["stderr"])]
    return t, refusal, images


def renders_figure(table: pd.DataFrame, images: dict, ref: np.ndarray):
    """Reference and every method at one exposure; relMSE per method and region (log scale)."""
    fig = plt.figure(figsize=(13.5, 10), layout="constrained")
    grid = fig.add_gridspec(3, 4, height_ratios=[1, 1, 1.05])
    exposure = exposure_of(ref)
    t = table.set_index("method")
    spp = int(table["spp"].iloc[0])
    show_image(fig.add_subplot(grid[0, 0]), ref, exposure, f"reference (mis-power, {table.attrs['ref_spp']} spp)")
    for k, (label, img) in enumerate(images.items(), start=1):
        ax = fig.add_subplot(grid[k // 4, k % 4])
        show_image(ax, img, exposure, f"{label}, {spp} spp")
        ax.set_xlabel(f"relMSE {t.loc[label, 'relmse']:.3g}", fontsize=9)
    ax = fig.add_subplot(grid[1, 3])
    ax.axis("off")
    ax.text(0.0, 0.5, f"every method: {spp} spp,\ntwo evaluations per camera ray\n"
                      "(one light + one BSDF sample\nfor MIS; two of one kind else)\n\n"
                      f"relMSE over the {int(table['pixels'].iloc[0])} surface\npixels, reference variance\nsubtracted\n\n"
                      f"{EXPOSURE_NOTE}", fontsize=9, va="center")
    ax = fig.add_subplot(grid[2, :])
    cols = ["relmse"] + [f"relmse {r}" for r in REGIONS]
    pos = np.arange(len(table))
    width = 0.8 / len(cols)
    hatches = ("", "//", "..", "xx")
    for j, (col, hatch) in enumerate(zip(cols, hatches)):
        ax.bar(pos + (j - (len(cols) - 1) / 2) * width, table[col], width, hatch=hatch, edgecolor="k", lw=0.5,
               color=[COLOURS[m] for m in table["method"]])
    keys = [Patch(facecolor="white", edgecolor="k", hatch=h, label=c[7:] or "all surface pixels")
            for c, h in zip(cols, hatches)]
    ax.set_yscale("log")
    ax.set_xticks(pos, table["method"])
    ax.set_xlabel("method (light: the envmap sampled uniformly or by luminance × sin θ)")
    ax.set_ylabel(f"relMSE at {spp} spp (dimensionless)")
    ax.set_title("error of each method: all surface pixels, then floor, diffuse sphere, glossy sphere", fontsize=10)
    ax.legend(handles=keys, fontsize=8, ncols=4)
    fig.suptitle("Environment lighting: sky with a small sun (2° radius) over a diffuse and a glossy sphere", fontsize=11)
    return fig


def map_figure(env: EnvironmentMap, fractions: dict):
    """The sky as the map stores it, and log10 of the luminance-sampling density p_w (1/sr)."""
    fig, axes = plt.subplots(1, 2, figsize=(13, 3.6), layout="constrained")
    ext = (0, 360, 180, 0)
    axes[0].imshow(display(env.image, exposure_of(env.image)), extent=ext, aspect="auto", interpolation="nearest")
    axes[0].set_title("environment image (lat-long; exposure: auto)", fontsize=9)
    axes[0].set_xticks([0, 90, 180, 270, 360]), axes[0].set_yticks([0, 45, 90, 135, 180])
    axes[0].set_xlabel("φ = 360° u (0: −z, 90°: +x)"), axes[0].set_ylabel("θ from +y (degrees)")
    h, w = env.height, env.width
    j, i = np.meshgrid(np.arange(1, h - 1), np.arange(w), indexing="ij")
    p = env.pdf(env.direction(np.stack([(i + 0.5) / w, j / (h - 1)], -1)))
    im = axes[1].imshow(np.log10(np.maximum(p, 1e-8)), extent=ext, aspect="auto", cmap="magma")
    bar = fig.colorbar(im, ax=axes[1])
    bar.set_label("log10 p_w (1/sr)")
    axes[1].set_xlabel("φ (degrees)"), axes[1].set_ylabel("θ (degrees)")
    axes[1].set_title(f"luminance × sin θ density; uniform: log10(1/4π) = {np.log10(1 / (4 * np.pi)):.2f}. "
                      f"Samples near the sun: {fractions['luminance']:.0%} against {fractions['uniform']:.2%}",
                      fontsize=9)
    return fig


def delta_figure(images: dict, table: pd.DataFrame):
    """The scene with the point light: light sampling and MIS at one exposure."""
    fig, axes = plt.subplots(1, len(images), figsize=(4.2 * len(images), 3.4), layout="constrained")
    exposure = exposure_of(images["light"])
    for ax, (label, img) in zip(axes, images.items()):
        t = table[table["method"] == label]
        show_image(ax, img, exposure, f"{label}, {int(t['spp'].iloc[0])} spp")
        ax.set_xlabel("mean R, G, B: " + ", ".join(f"{m:.4f}" for m in t["mean"]) +
                      ("" if label == "light" else f"\nmax |z| against light: {t['z_vs_light'].abs().max():.2f}"),
                      fontsize=9)
    fig.suptitle(f"sky + point light ('bsdf' is refused: it cannot reach the point light); {EXPOSURE_NOTE}", fontsize=10)
    return fig


def gallery_numbers(out: str | Path) -> dict:
    """The gallery caption's numbers, from ``environment_lighting_methods.csv``."""
    t = pd.read_csv(Path(out) / "environment_lighting_methods.csv").set_index("method")["relmse"]
    res = {k: f"{t[m]:.2g}" for k, m in (("bsdf", "bsdf"), ("uniform", "light, uniform map"),
                                         ("luminance", "light, luminance map"), ("balance", "mis-balance"),
                                         ("power", "mis-power"), ("optimal", OPTIMAL))}
    res["spp"] = int(pd.read_csv(Path(out) / "environment_lighting_methods.csv")["spp"].iloc[0])
    res["gain"] = f"{t['light, uniform map'] / t['light, luminance map']:.0f}"
    return res


def main(out: str | Path = DEFAULT_OUT, full: bool = False) -> dict:
    """Write the sky and scenes, run the comparison and both checks, write CSV + PNG into ``out``."""
    full = checks.flag(full, "full")
    out = output_dir(out)
    size, spp, ref_spp = ((320, 240), 32, 4096) if full else ((160, 120), 16, 512)
    paths = write_scenes(out, size)
    env = EnvironmentMap(read_environment(paths["sky"]))
    fractions = sun_fractions(env)
    save_figure(map_figure(env, fractions), out / "environment_lighting_map.png")

    table, images, ref = compare(paths, spp, ref_spp)
    table.to_csv(out / "environment_lighting_methods.csv", index=False)
    save_figure(renders_figure(table, images, ref), out / "environment_lighting_renders.png")

    const = constant_check(64 if full else 32, 64 if full else 16)
    const.to_csv(out / "environment_lighting_constant.csv", index=False)
    delta, refusal, delta_images = delta_check(paths, 256 if full else 64)
    delta.to_csv(out / "environment_lighting_point.csv", index=False)
    save_figure(delta_figure(delta_images, delta), out / "environment_lighting_point.png")

    rel = table.set_index("method")["relmse"]
    return {
        "methods": table, "constant": const, "point": delta,
        "relmse": rel.to_dict(), "seconds": table.set_index("method")["seconds"].to_dict(),
        "luminance_gain": float(rel["light, uniform map"] / rel["light, luminance map"]),
        "sun_fraction": fractions, "constant_ok": bool(const["ok"].all()),
        "bsdf_refusal": refusal,
        "size": size, "spp": spp, "ref_spp": ref_spp, "ref_seconds": table.attrs["ref_seconds"],
        "files": sorted(p.name for p in out.iterdir()),
    }


if __name__ == "__main__":
    experiment_cli(main, DEFAULT_OUT, __doc__)
