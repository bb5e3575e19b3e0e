"""The distribution of visible microfacet normals (VNDF), given the direction ``wo`` they are seen from.

Measure: solid angle of m.  Density (Heitz & d'Eon 2014, "Importance Sampling Microfacet-Based
BSDFs using the Distribution of Visible Normals", eq. 2; Heitz 2018, eq. 1):

    D_wo(m) = G1(wo, m) max(0, wo.m) D(m) / wo_z,   G1 = 1 / (1 + Lambda(wo)) exact,

normalised because int max(0, wo.m) D(m) dm = wo_z (1 + Lambda(wo)) (the projected area of the
microsurface seen from wo).  All samplers work in the stretched configuration (alpha_u = alpha_v
= 1): wo is stretched to wh = normalize(alpha_u wo_x, alpha_v wo_y, wo_z), with polar angle
theta and azimuth phi (phi = 0 at wh = +z), a normal Nh is drawn visible from wh for the NDF
with alpha = 1, and unstretched, m = normalize(alpha_u Nh_x, alpha_v Nh_y, Nh_z) (Heitz 2014,
sec. 5.3; slopes scale by alpha).  In the frame T1 = (-sin phi, cos phi, 0),
T2 = wh x T1 = (-cos theta cos phi, -cos theta sin phi, sin theta), wh:

* GGX (Heitz 2018, "Sampling the GGX Distribution of Visible Normals", JCGT 7(4)): the visible
  projected hemisphere of radius 1 around wh is an ellipse-capped disk: (x, y) uniform on the unit
  disk (the concentric map of u, as Mitsuba 3, where Heitz uses the polar map), t1 = -x,
  t2 = (1 - s) sqrt(1 - x^2) + s y with s = (1 + cos theta) / 2, lifted to
  Nh = t1 T1 + t2 T2 + sqrt(1 - t1^2 - t2^2) wh.  Exact; the sign t1 = -x and the concentric map
  make the same ``u`` give Mitsuba 3's normal.  ``invert`` undoes each step (closed form).
* Beckmann (Heitz & d'Eon 2014 sec. 4, with Jakob's improved routine, "An Improved Visible Normal
  Sampling Routine for the Beckmann Distribution", 2014, as Mitsuba 3): the stretched slopes
  (x, y) of Nh ~ (-x, -y, 1) in the frame of wh are independent; y = erfinv(2 u2 - 1) and x has
  the CDF  C(x) = (1 + erf(x) + tan(theta) exp(-x^2) / sqrt(pi)) / (1 + erf(cot theta) +
  tan(theta) exp(-cot^2 theta) / sqrt(pi))  on x < cot(theta).  There is no closed-form inverse:
  C(x) = u1 is solved by ``newton_steps`` (default 3, Mitsuba's) Newton steps in X = erf(x), from
  the exact solution at grazing incidence, X0 = erf(cot) - (erf(cot) + 1) erf(sqrt(-log u1)),
  with derivative dC/dX ~ 1 - x tan(theta).  ``invert`` evaluates C (closed form), so
  ``invert(sample(u))`` returns u up to the Newton residual.  As Mitsuba, u is clamped to
  [1e-6, 1 - 1e-6]: slopes beyond erfinv(1 - 2e-6) = 3.46 (stretched) are never drawn, a mass
  below 4e-6 that ``pdf`` does not leave out.

What is exact: the GGX sampler draws exactly ``pdf`` (= ``pdf_mitsuba``, GGX's G1 is exact).  The
Beckmann sampler draws the exact-Lambda density ``pdf`` up to the Newton residual and the u clamp
(both far below what a chi-square test resolves).  Mitsuba 3's ``MicrofacetDistribution.pdf(wi, m)``
multiplies by its rational G1 instead: ``pdf_mitsuba`` reproduces that value, which differs from
the density of the samples by G1_rational / G1_exact (within 0.35 %) and does not integrate to
1.  An unbiased estimator divides by ``pdf``; a BSDF that must reproduce Mitsuba's per-sample
values (MIS weights, sample weights) uses ``pdf_mitsuba`` and inherits that bias.

Checks: ``normals`` a ``GGX`` or ``Beckmann``; ``wo`` finite, non-zero (normalised here), z > 0
(flip a lower-hemisphere direction, and the normal, first); ``newton_steps`` an integer in
[1, 50].  ``sample``/``pdf``/``invert`` check shapes and that their leading axes broadcast with
``wo``'s.
"""
from __future__ import annotations

from typing import Any

import numpy as np

from .. import checks
from .base import as_points, as_uniforms, check_broadcast
from .frames import normalize
from .planar import concentric_disk, concentric_disk_inverse
from .spherical import _Direction

__all__ = ["VisibleNormals"]

INV_SQRT_PI = float(1.0 / np.sqrt(np.pi))
U_CLAMP = 1e-6          # the Beckmann sampler clamps u to [U_CLAMP, 1 - U_CLAMP] (as Mitsuba 3)


class VisibleNormals(_Direction):
    """Microfacet normals m visible from ``wo``: density G1(wo, m) max(0, wo.m) D(m) / wo_z.

    ``normals``: a ``GGX`` or ``Beckmann`` (isotropic or anisotropic); ``wo``: the direction
    (``(3,)`` or a batch ``(..., 3)`` broadcast with the leading axes of ``u`` and ``m``),
    z > 0; ``newton_steps``: Beckmann's Newton iterations.  See the module docstring for the
    constructions, what is exact and ``pdf`` against ``pdf_mitsuba``.
    """

    def __init__(self, normals: Any, wo: Any, newton_steps: int = 3):
        # a GGX or Beckmann, by the kind they declare (microfacet.py imports this module)
        self._ggx = getattr(normals, "visible_kind", None) == "ggx"
        if getattr(normals, "visible_kind", None) not in ("ggx", "beckmann"):
            raise TypeError(f"normals must be a GGX or Beckmann distribution, got {checks.describe(normals)}")
        self.normals = normals
        self.wo = normalize(wo, "wo")
        if not np.all(self.wo[..., 2] > 0):
            raise ValueError("wo: directions must lie in the upper hemisphere (z > 0); flip wo (and the "
                             "normal) first")
        self.newton_steps = checks.integer(newton_steps, "newton_steps", low=1, high=50)
        self._batch = self.wo.shape[:-1]
        au, av = normals.alpha_u, normals.alpha_v
        wh = normalize(np.stack([au * self.wo[..., 0], av * self.wo[..., 1], self.wo[..., 2]], -1), "wo")
        self.cos_theta = wh[..., 2]
        self.sin_theta = np.hypot(wh[..., 0], wh[..., 1])
        flat = self.sin_theta == 0
        inv = 1.0 / np.where(flat, 1.0, self.sin_theta)
        self.cos_phi = np.where(flat, 1.0, wh[..., 0] * inv)
        self.sin_phi = np.where(flat, 0.0, wh[..., 1] * inv)

    # -- the frame (T1, T2, wh) of the stretched direction ------------------------------------
    def _frame(self):
        ct, st, cp, sp = self.cos_theta, self.sin_theta, self.cos_phi, self.sin_phi
        zero = np.zeros_like(ct)
        t1 = np.stack([-sp, cp, zero], -1)
        t2 = np.stack([-ct * cp, -ct * sp, st], -1)
        wh = np.stack([st * cp, st * sp, ct], -1)
        return t1, t2, wh

    def _unstretch(self, n: np.ndarray) -> np.ndarray:
        m = np.stack([self.normals.alpha_u * n[..., 0], self.normals.alpha_v * n[..., 1],
                      np.maximum(n[..., 2], 0.0)], -1)
        return m / np.linalg.norm(m, axis=-1, keepdims=True)

    def _stretch(self, m: np.ndarray) -> np.ndarray:
        n = np.stack([m[..., 0] / self.normals.alpha_u, m[..., 1] / self.normals.alpha_v, m[..., 2]], -1)
        return n / np.linalg.norm(n, axis=-1, keepdims=True)

    def _beckmann_terms(self):
        """(tan theta, cot theta, erf(cot theta), the CDF's normalisation)."""
        from scipy.special import erf

        with np.errstate(divide="ignore"):
            tan = self.sin_theta / self.cos_theta
            cot = self.cos_theta / self.sin_theta             # inf at normal incidence
        maxval = erf(cot)
        norm = 1.0 + maxval + INV_SQRT_PI * tan * np.exp(-cot * cot)
        return tan, cot, maxval, norm

    # -- sample / pdf / invert ----------------------------------------------------------------
    def sample(self, u):
        u = check_broadcast(as_uniforms(u, 2), "u", self._batch, "wo")
        if self._ggx:
            t1, t2, wh = self._frame()
            d = concentric_disk(u)
            x, y = d[..., 0], d[..., 1]
            s = 0.5 * (1.0 + self.cos_theta)
            b = (1.0 - s) * np.sqrt(np.clip(1.0 - x * x, 0.0, None)) + s * y
            h = np.sqrt(np.clip(1.0 - x * x - b * b, 0.0, None))
            n = -x[..., None] * t1 + b[..., None] * t2 + h[..., None] * wh
            return self._unstretch(n)
        return self._sample_beckmann(u)

    def _sample_beckmann(self, u):
        from scipy.special import erf, erfinv

        tan, _, maxval, norm = self._beckmann_terms()
        u = np.clip(u, U_CLAMP, 1.0 - U_CLAMP)
        x = maxval - (maxval + 1.0) * erf(np.sqrt(-np.log(u[..., 0])))
        target = u[..., 0] * norm
        with np.errstate(invalid="ignore"):
            for _ in range(self.newton_steps):
                slope = erfinv(x)
                value = 1.0 + x + INV_SQRT_PI * tan * np.exp(-slope * slope) - target
                x = x - value / (1.0 - slope * tan)
        sx, sy = erfinv(x), erfinv(2.0 * u[..., 1] - 1.0)
        cp, sp = self.cos_phi, self.sin_phi
        # the stretched slopes turned by phi; the normal of slope (p, q) is (-p, -q, 1)
        n = np.stack([-(cp * sx - sp * sy), -(sp * sx + cp * sy), np.ones_like(sx)], -1)
        return self._unstretch(n)

    def _dot(self, m: np.ndarray) -> np.ndarray:
        w = self.wo
        return w[..., 0] * m[..., 0] + w[..., 1] * m[..., 1] + w[..., 2] * m[..., 2]

    def pdf(self, m):
        """G1_exact(wo, m) max(0, wo.m) D(m) / wo_z: the density of ``sample``'s normals."""
        m = check_broadcast(as_points(m, 3, "m"), "m", self._batch, "wo")
        g = self.normals.G1_exact(self.wo, m)
        return self.normals.D(m) * g * np.maximum(self._dot(m), 0.0) / self.wo[..., 2]

    def pdf_mitsuba(self, m):
        """Mitsuba 3's ``pdf(wi, m)`` with visible-normal sampling: D(m) G1(wo, m) |wo.m| / wo_z with
        its G1 (rational for Beckmann: not exactly the density of the samples; equal to ``pdf``
        for GGX)."""
        m = check_broadcast(as_points(m, 3, "m"), "m", self._batch, "wo")
        g = self.normals.G1(self.wo, m)
        return self.normals.D(m) * g * np.abs(self._dot(m)) / self.wo[..., 2]

    def invert(self, m):
        m = check_broadcast(as_points(m, 3, "m"), "m", self._batch, "wo")
        n = self._stretch(m)
        if self._ggx:
            t1, t2, _ = self._frame()
            a = np.sum(n * t1, -1)
            b = np.sum(n * t2, -1)
            s = 0.5 * (1.0 + self.cos_theta)
            y = (b - (1.0 - s) * np.sqrt(np.clip(1.0 - a * a, 0.0, None))) / s
            return concentric_disk_inverse(np.stack([-a, y], -1))
        from scipy.special import erfc

        tan, _, _, norm = self._beckmann_terms()
        with np.errstate(divide="ignore", invalid="ignore"):
            p, q = -n[..., 0] / n[..., 2], -n[..., 1] / n[..., 2]
        cp, sp = self.cos_phi, self.sin_phi
        x, y = cp * p + sp * q, -sp * p + cp * q
        u1 = (erfc(-x) + INV_SQRT_PI * tan * np.exp(-x * x)) / norm
        return np.stack([u1, 0.5 * erfc(-y)], -1)

    def _repr_fields(self):
        out = {"normals": self.normals, "wo": self.wo.tolist() if self.wo.ndim == 1 else f"<{self._batch}>"}
        if not self._ggx and self.newton_steps != 3:
            out["newton_steps"] = self.newton_steps
        return out
