"""The bias and error-bar battery of the render presets: independent seeds at low spp.

For a scene, a preset and an spp, :func:`seed_battery` renders ``seeds`` images with
independent seeds (``SeedSequence([seed0, s])``) on a small film and compares

- **bias**: the image mean over seeds, M = mean_s mean_pixels(I_s), with a high-spp
  reference's mean (:func:`reference_mean`): z = (M - mu_ref) / sqrt(v / S + se_ref^2),
  where v is the per-seed variance of the image mean.  Heavy tails (a small bright light
  found by directions that rarely reach it) make S seeds' spread understate v: v is the
  larger of the spread over seeds and the variance that one long render of the same preset
  (``long_factor`` x spp) reports, scaled to spp (the mean of its per-pixel stderr^2 over
  the pixels, times long_factor, over the number of pixel-channels, as pixels are
  independent).  An unbiased preset gives |z| < 4.5 with probability ~1 - 7e-6;
- **error bars**: the reported per-pixel variance (stderr^2, averaged over seeds and
  pixels) over the variance of the pixel values across seeds (averaged over pixels): 1 when
  the error bars are honest.

Used by ``tests/test_bias_battery.py`` and ``benchmarks/bench_error_bars.py``.
"""
from __future__ import annotations

from typing import Any

import numpy as np

__all__ = ["seed_battery", "reference_mean", "battery_scenes", "BIAS_Z"]

#: |z| above which an unbiased preset's image mean is rejected
BIAS_Z = 4.5


def reference_mean(scene, spp: int = 2048, strategy: str = "mis-power", rng: Any = 12345) -> tuple[float, float]:
    """``(mean, stderr)`` of the image mean of a ``strategy`` render at ``spp``."""
    from ..render import render

    ref = render(scene, spp, strategy, rng=rng)
    return float(np.mean(ref.value)), float(np.sqrt(np.sum(ref.stderr.astype(float) ** 2)) / ref.stderr.size)


def seed_battery(scene, preset: Any, spp: int, reference: tuple[float, float], *, seeds: int = 24,
                 seed0: int = 0, long_factor: int = 24, **settings: Any) -> dict:
    """Bias z-score and error-bar ratio of ``preset`` at ``spp`` over ``seeds`` seeds (module
    docstring).  ``reference``: ``(mean, stderr)`` of :func:`reference_mean`.  Returns
    ``z``, ``mean_ratio`` (M / mu_ref), ``bar_ratio`` (reported / spread variance),
    ``spread_var``, ``long_var`` (per seed) and the per-seed image means ``means``."""
    from ..render import render

    images, variances = [], []
    for s in range(seeds):
        est = render(scene, spp, preset, rng=np.random.SeedSequence([seed0, s]), **settings)
        images.append(np.asarray(est.value, float))
        variances.append(np.asarray(est.stderr, float) ** 2)
    images, variances = np.stack(images), np.stack(variances)
    means = images.reshape(seeds, -1).mean(-1)
    cells = images[0].size
    spread_var = float(np.var(means, ddof=1))
    long = render(scene, spp * long_factor, preset, rng=np.random.SeedSequence([seed0, seeds]), **settings)
    long_var = float(np.nanmean(np.asarray(long.stderr, float) ** 2) * long_factor / cells)
    v = max(spread_var, long_var)
    mu, se = reference
    z = (means.mean() - mu) / np.sqrt(v / seeds + se ** 2)
    per_pixel_spread = np.var(images, axis=0, ddof=1)
    reported = variances[np.isfinite(variances)]            # one unit per pixel: no error bar (NaN)
    with np.errstate(invalid="ignore", divide="ignore"):
        bar_ratio = float(reported.mean() / np.mean(per_pixel_spread)) if reported.size else float("nan")
    return {"z": float(z), "mean_ratio": float(means.mean() / mu) if mu else float("nan"), "bar_ratio": bar_ratio,
            "spread_var": spread_var, "long_var": long_var, "means": means}


_VIEW = ('<sensor type="perspective"><float name="fov" value="50"/><transform name="to_world"><lookat '
         'origin="0.3, 2.2, 3.4" target="0, 0.3, 0" up="0, 1, 0"/></transform><film type="hdrfilm"><integer '
         'name="width" value="{w}"/><integer name="height" value="{h}"/><rfilter type="box"/></film></sensor>')
_FLOOR = ('<shape type="rectangle"><transform name="to_world"><scale value="3"/><rotate x="1" angle="-90"/>'
          '</transform><bsdf type="diffuse"><rgb name="reflectance" value="0.6, 0.5, 0.4"/></bsdf></shape>')
_SPHERE = ('<shape type="sphere"><point name="center" value="0, 0.5, 0"/><float name="radius" value="0.5"/>'
           '<bsdf type="roughplastic"><float name="alpha" value="0.15"/><rgb name="diffuse_reflectance" '
           'value="0.3, 0.4, 0.6"/></bsdf></shape>')
_DELTA = ('<emitter type="point"><point name="position" value="-1, 2, 1"/><rgb name="intensity" value="4, 4, 3"/>'
          '</emitter><emitter type="spot"><transform name="to_world"><lookat origin="1.5, 2.5, 0.5" target="0, 0, 0"/>'
          '</transform><rgb name="intensity" value="6, 5, 8"/><float name="cutoff_angle" value="30"/></emitter>'
          '<shape type="sphere"><point name="center" value="1.1, 0.9, 0.4"/><float name="radius" value="0.15"/>'
          '<emitter type="area"><rgb name="radiance" value="3, 5, 8"/></emitter></shape>')


def battery_scenes(folder, width: int = 12, height: int = 9) -> dict:
    """``{name: Scene}`` of the battery at ``width`` x ``height``: the built-in ``cornell_box``
    and ``veach_mis``, ``delta_lights`` (a point, a spot and a small spherical area light over a
    floor and a rough-plastic sphere) and ``envmap`` (the sphere and floor under an environment
    map with a small bright sun, written as ``envmap.exr`` into ``folder``)."""
    from pathlib import Path

    from ..render import load_scene
    from ..render.builtin import builtin_scene_path
    from ..render.image import save_image

    env = np.random.default_rng(0).random((16, 32, 3)).astype(np.float32) * 0.5
    env[3:5, 20:23] = 30.0
    path = save_image(Path(folder) / "envmap.exr", env)
    view = _VIEW.format(w=width, h=height)
    xml = {"delta_lights": _FLOOR + _SPHERE + _DELTA,
           "envmap": _FLOOR + _SPHERE + f'<emitter type="envmap"><string name="filename" value="{path}"/></emitter>'}
    out = {name: load_scene(builtin_scene_path(name)).with_size(width, height) for name in ("cornell_box", "veach_mis")}
    for name, body in xml.items():
        out[name] = load_scene(f'<scene version="3.0.0"><integrator type="direct"/>{view}{body}</scene>')
    return out
