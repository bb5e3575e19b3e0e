"""Mitsuba 3 references of a scene for :mod:`vrlab.testing.mitsuba`: the scene's XML made
ready for both renderers (file names absolute), its integrator wrapped in Mitsuba's
``moment`` integrator, and :func:`mitsuba_reference` (per-pixel mean and per-sample variance,
in CIE XYZ).  Importing this module does not import Mitsuba."""
from __future__ import annotations

import os
import xml.etree.ElementTree as ET
from pathlib import Path
from typing import Any

import numpy as np

from .. import checks

__all__ = ["REFERENCE_BATCH_SPP", "mitsuba_reference"]

#: Samples per pixel of one ``mi.render`` call of :func:`mitsuba_reference`, whose batches are
#: summed in float64: Mitsuba's float32 pixel sums drift (a constant pixel of value 3-4: 1e-4
#: relative error and m2 - mean^2 = 6e-3 at 16384 spp in one call; 3e-6 and 1e-4 at 256 spp).
REFERENCE_BATCH_SPP = 256


# ----------------------------------------------------------------------------- scene XML
def _scene_xml(scene: Any, base: Any) -> tuple[ET.Element, Path]:
    """The parsed ``<scene>`` root of a path or XML string (or built-in name) and its base folder."""
    if isinstance(scene, str) and scene.lstrip().startswith("<"):
        text, folder = scene, Path.cwd() if base is None else Path(base)
    elif isinstance(scene, (str, os.PathLike)) and not isinstance(scene, bytes):
        path = Path(scene)
        if not path.is_file() and isinstance(scene, str):
            from ..render import builtin_scene_path, list_builtin_scenes
            stem = scene[:-4] if scene.endswith(".xml") else scene
            if stem not in list_builtin_scenes():
                raise ValueError(f"scene: {scene!r} is neither an XML string (starting with '<'), a scene "
                                 f"file nor a built-in scene ({', '.join(list_builtin_scenes())})")
            path = builtin_scene_path(stem)
        if not path.is_file():
            raise ValueError(f"scene: no scene file {str(path)!r}")
        text, folder = path.read_text(encoding="utf-8"), path.parent if base is None else Path(base)
    else:
        raise TypeError(f"scene must be a scene file path or an XML string, got {checks.describe(scene)}")
    if base is not None and not (isinstance(base, (str, os.PathLike)) and Path(base).is_dir()):
        raise ValueError(f"base must be an existing folder, got {checks.describe(base)}")
    try:
        root = ET.fromstring(text)
    except ET.ParseError as exc:
        raise ValueError(f"scene: not well-formed XML ({exc})") from None
    if root.tag != "scene" or "version" not in root.attrib:
        raise ValueError('scene: the root element must be <scene version="3.x.y"> (Mitsuba needs the version)')
    for el in root.iter():      # relative file names -> absolute, for both loaders
        is_file = (el.tag == "string" and el.get("name") == "filename") or el.tag == "include"
        key = "value" if el.tag == "string" else "filename"
        v = el.get(key)
        if is_file and v and "$" not in v and not Path(v).is_absolute():
            el.set(key, str((folder / v).resolve()))
    return root, folder


def _moment_xml(root: ET.Element) -> tuple[str, str]:
    """XML text with the integrator wrapped in ``moment`` (kept if it already is one; Mitsuba's
    default ``path`` if there is none) and the name of the nested integrator whose AOVs are read."""
    for sensor in root.iter("sensor"):
        # the sample pattern changes only the noise: the reference draws i.i.d. samples, so that
        # m2 - mean^2 is the per-sample variance.  With a filter wider than the box, Mitsuba's
        # film gives the filter-weighted mean and second moment of the samples around each pixel,
        # whose difference is the per-sample variance of vrlab's filter-importance-sampled pixels.
        for sampler in sensor.findall("sampler"):
            sampler.set("type", "independent")
            for c in list(sampler):
                if c.get("name") not in ("sample_count", "seed"):
                    sampler.remove(c)
    integrators = root.findall("integrator")
    if len(integrators) > 1:
        raise ValueError(f"scene: at most one <integrator>, got {len(integrators)}")
    integ = integrators[0] if integrators else ET.Element("integrator", type="path")
    if integ.get("type") == "moment":
        nested = integ.findall("integrator")
        if not nested:
            raise ValueError("scene: its moment integrator has no nested integrator")
        inner, moment = nested[0], integ
    else:       # the moment integrator takes the place of the scene's (after its <default>s)
        at = list(root).index(integ) if integrators else len(root)
        if integrators:
            root.remove(integ)
        inner, moment = integ, ET.Element("integrator", type="moment")
        moment.append(inner)
        root.insert(at, moment)
    inner.attrib.pop("id", None)
    inner.set("name", inner.get("name") or "vrlab_nested")
    return ET.tostring(root, encoding="unicode"), inner.get("name")


def _params(params: Any) -> dict[str, str]:
    if params is not None and not (isinstance(params, dict) and all(isinstance(k, str) for k in params)):
        raise TypeError(f"params must be a dict from parameter names to values, got {checks.describe(params)}")
    return {k: str(v).lower() if isinstance(v, bool) else ", ".join(map(str, v)) if isinstance(v, (list, tuple))
            else str(v) for k, v in (params or {}).items()}


def mitsuba_reference(scene: Any, spp: int, *, seed: int = 0, variant: str = "scalar_rgb",
                      base: Any = None, params: dict | None = None) -> tuple[np.ndarray, np.ndarray]:
    """``(mean, var)``, both (H, W, 3) float64 in CIE XYZ: Mitsuba 3's render of ``scene`` with
    ``spp`` samples per pixel, its integrator wrapped in Mitsuba's ``moment`` integrator (a
    scene that already uses ``moment``: its first nested integrator is read).

    For pixel p with samples x_1..x_n (n = ``spp``; one camera ray each, i.i.d.: the scene's
    sampler is replaced by ``independent``; with a box filter each sample is in one pixel,
    with a wider one the sums below are the film's filter-weighted ones), ``mean = (1/n) sum x_i`` and
    ``var = max(m2 - mean^2, 0)`` with ``m2 = (1/n) sum x_i^2``, per XYZ channel: the per-sample
    variance of the pixel estimator (the biased, 1/n, sample variance; ``var / spp`` is the
    variance of ``mean``), as Mitsuba's render test uses it.  Mitsuba 3 convention:
    ``bitmap_extract`` in src/render/tests/test_renders.py; the moment integrator records
    ``srgb_to_xyz`` of each sample and its square (src/integrators/moment.cpp).  The samples
    are rendered in ``mi.render`` calls of :data:`REFERENCE_BATCH_SPP` samples per pixel (seeds
    derived from ``seed``, never sharing a pixel's random stream) whose mean and m2 are summed
    in float64: Mitsuba's float32 sums lose precision over many samples.

    ``scene``: a scene file path, a built-in scene name or an XML string (``<scene version=...>``
    is required by Mitsuba's loader); relative file names in it are resolved against the file's
    folder, or ``base`` (default: the current folder for strings).  ``params`` override the
    scene's ``<default>`` values.  ``variant``: a Mitsuba variant with RGB or spectral colour.
    """
    root, _ = _scene_xml(scene, base)
    spp = checks.integer(spp, "spp", low=1, high=1 << 31)
    seed = checks.integer(seed, "seed", low=0, high=(1 << 32) - 1)
    kwargs = _params(params)
    xml, name = _moment_xml(root)
    try:
        import mitsuba as mi
    except ImportError:
        raise ImportError("mitsuba_reference needs Mitsuba 3: pip install mitsuba") from None
    if not isinstance(variant, str) or variant not in mi.variants() or "mono" in variant:
        raise ValueError(f"variant must be one of Mitsuba's RGB or spectral variants "
                         f"{[v for v in mi.variants() if 'mono' not in v]}, got {variant!r}")
    previous = mi.variant()
    mi.set_variant(variant)
    try:
        try:
            mscene = mi.load_string(xml, **kwargs)
        except Exception as exc:            # Mitsuba raises RuntimeError/ValueError with its own text
            raise ValueError(f"scene: Mitsuba cannot load it: {exc}") from None
        w, h = (int(n) for n in mscene.sensors()[0].film().crop_size())
        sizes = [REFERENCE_BATCH_SPP] * (spp // REFERENCE_BATCH_SPP) + [spp % REFERENCE_BATCH_SPP] * (
            spp % REFERENCE_BATCH_SPP > 0)
        # scalar variants seed pixel i of block b with s W H + b B^2 + i (B <= 32: block side):
        # seeds a multiple ``stride`` apart never share a pixel stream
        stride = -(-(w + 31) * (h + 31) // (w * h))
        if (seed + 1) * len(sizes) * stride * w * h >= 1 << 32:
            raise ValueError(f"seed: too large for {len(sizes)} batches of a {w}x{h} image "
                             "(Mitsuba's pixel seeds are 32-bit)")
        mean = m2 = 0.0
        for k, n in enumerate(sizes):
            mi.render(mscene, spp=n, seed=(seed * len(sizes) + k) * stride)
            layers = dict(mscene.sensors()[0].film().bitmap(raw=False).split())
            mean = mean + n / spp * np.array(layers[name], dtype=np.float64)
            m2 = m2 + n / spp * np.array(layers["m2_" + name], dtype=np.float64)
    finally:
        if previous is not None and previous != variant:
            mi.set_variant(previous)
    return mean, np.maximum(m2 - mean * mean, 0.0)


