"""``envmap`` (Mitsuba 3): an environment at infinity given by a latitude-longitude image
(``filename``: EXR linear, 8/16-bit images decoded from sRGB; alpha dropped), ``scale``
(default 1), ``to_world`` (a rotation of the map; +y is up) and ``mis_compensation``
(default false).  Radiance along a direction is Mitsuba's bilinear texel lookup, and
directions are importance-sampled from the image's luminance times sin(theta) over its
cells, p_w = p_uv / (2 pi^2 sin theta) (:class:`vrlab.distributions.EnvironmentMap`, with
its chi-square tests and its agreement with Mitsuba's ``eval``/``pdf_direction``).

``mis_compensation`` subtracts the mean luminance before building the density (Karlík et al.
2019, "MIS compensation"): the density is then zero on the dim parts of the map, which only
another technique (BSDF sampling under MIS) covers; alone, light sampling is biased there,
and the renderer does not hide it (use it with ``mis-*`` estimators).  ``sampling`` (a vrlab
parameter, which Mitsuba refuses): ``"luminance"`` (default, as above) or ``"uniform"``
(directions uniform on the sphere, density 1 / (4 pi): the baseline the luminance map is
measured against)."""
from __future__ import annotations

from typing import Any

import numpy as np

from ... import checks
from ..registry import register
from .base import Emitter, weight_param

__all__ = ["EnvironmentEmitter", "read_environment"]


def read_environment(path) -> np.ndarray:
    """The linear RGB ``(H, W, 3)`` of an environment image, as Mitsuba reads it."""
    from ..image import read_bitmap, srgb_decode

    b = read_bitmap(path)
    rgb = b.data[..., :3] if b.channels.startswith("RGB") else np.repeat(b.data[..., :1], 3, -1)
    return srgb_decode(rgb) if b.srgb else rgb


@register("emitter", "envmap")
class EnvironmentEmitter(Emitter):
    """``EnvironmentEmitter(image=None, filename=None, scale=1, to_world=None, mis_compensation=False,
    sampling_weight=1)``: give the image ``(H, W, 3)`` or a file."""

    is_infinite = True

    SAMPLING = ("luminance", "uniform")

    def __init__(self, *, image: Any = None, filename: Any = None, scale: float = 1.0, to_world: Any = None,
                 mis_compensation: bool = False, sampling_weight: float = 1.0, sampling: str = "luminance"):
        from ...distributions import EnvironmentMap, UniformSphere

        self.sampling = checks.choice(sampling, "sampling", self.SAMPLING)
        self._uniform = UniformSphere()

        if (image is None) == (filename is None):
            raise ValueError("filename: give either an image or a filename")
        if filename is not None:
            image = read_environment(filename)
        self.filename = None if filename is None else str(filename)
        self.scale = checks.real(scale, "scale", low=0)
        m = None if to_world is None else np.asarray(to_world, float)
        try:
            self.map = EnvironmentMap(image, to_world=m, scale=self.scale,
                                      mis_compensation=checks.flag(mis_compensation, "mis_compensation"))
        except ValueError as exc:
            msg = str(exc)
            raise ValueError(msg if msg.split(":")[0].split(" ")[0] in ("to_world", "scale", "image")
                             else f"filename: {msg}") from None
        self.sampling_weight = weight_param(sampling_weight)

    @classmethod
    def from_props(cls, p) -> "EnvironmentEmitter":
        return cls(filename=p.filename("filename"), scale=p.float("scale", 1.0),
                   to_world=p.transform("to_world") if p.has("to_world") else None,
                   mis_compensation=p.bool("mis_compensation", False), sampling_weight=p.float("sampling_weight", 1.0),
                   sampling=p.string("sampling", "luminance", cls.SAMPLING))

    def sample(self, ref, u):
        if self.sampling == "uniform":
            w = np.asarray(self._uniform.sample(np.asarray(u, float)), ref.dtype)
            pdf = np.full(len(ref), 1.0 / (4 * np.pi))
        else:
            w, pdf = self.map.sample_pdf(np.asarray(u, float))
            w = np.asarray(w, ref.dtype)
        return w, pdf, self.radiance(ref, w), np.full(len(ref), np.inf)

    def pdf(self, ref, w):
        if self.sampling == "uniform":
            return np.full(len(ref), 1.0 / (4 * np.pi))
        return np.asarray(self.map.pdf(np.asarray(w, float)), float)

    def radiance(self, ref, w):
        return np.asarray(self.map.eval(np.asarray(w, float)), np.float32)

    def power(self, radius: float) -> float:
        return float(4 * np.pi * np.pi * radius * radius * np.mean(self.map.eval(
            self.map.direction(np.random.default_rng(0).random((4096, 2))))))
