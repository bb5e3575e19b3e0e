"""``thindielectric``: a thin dielectric slab such as a window pane modelled as one sheet
(Mitsuba 3 ``thindielectric``, src/bsdfs/thindielectric.cpp).

Light crossing the slab leaves it undeflected, so there are two delta lobes on both sides:

* ``"reflection"``: wi = mirror(wo) = (-x, -y, z), value ``specular_reflectance * R'``;
* ``"transmission"``: wi = -wo (straight through), value ``specular_transmittance * (1 - R')``,

where R = F(|cos theta_o|) is the Fresnel reflectance of one interface of relative index
eta = ``int_ior / ext_ior`` (:func:`~vrlab.render.bsdfs.fresnel.fresnel_dielectric`) and R' sums
the slab's internal reflections, R, TRT, TR^3T, ... with T = 1 - R:

    R' = R + T^2 R / (1 - R^2) = 2 R / (1 + R).

No 1 / eta^2 factor: the light returns to the outside medium.  Sampling (Mitsuba's): reflection
with probability R', transmission with 1 - R'; ``eval`` and ``pdf`` are 0.  Parameters as
``dielectric``'s: ``int_ior`` ("bk7"), ``ext_ior`` ("air"), ``specular_reflectance`` and
``specular_transmittance`` (1, colours or textures).
"""
from __future__ import annotations

import numpy as np

from ..registry import register
from .dielectric import SmoothInterface
from .fresnel import fresnel_dielectric

__all__ = ["ThinDielectric"]


@register("bsdf", "thindielectric")
class ThinDielectric(SmoothInterface):
    """Thin dielectric slab (see the module docstring): delta lobes ``"reflection"`` (R') and
    ``"transmission"`` (1 - R', straight through), both sides."""

    def _lobes(self, wo):
        R = fresnel_dielectric(np.abs(wo[..., 2]), self.eta).F
        R = 2.0 * R / (1.0 + R)
        return R, -wo, np.ones((), wo.dtype)
