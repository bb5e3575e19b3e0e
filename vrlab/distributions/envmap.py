"""Environment maps: Mitsuba 3's ``envmap`` emitter as a direction distribution.

Conventions (Mitsuba 3 convention, src/emitters/envmap.cpp; checked against Mitsuba 3.9.1's
``scalar_rgb`` variant in tests/test_envmap.py):

* **Directions and uv.**  The image is a latitude-longitude map with **+y up** in the
  emitter's local frame.  A local direction d = (x, y, z) has
  ``u = atan2(x, -z) / (2 pi)`` (taken in [0, 1)) and ``v = theta / pi`` with
  ``cos theta = y``; back: ``theta = pi v``, ``phi = 2 pi u``,
  ``d = (sin phi sin theta, cos theta, -cos phi sin theta)``.  So u = 0 looks along -z,
  u grows towards +x (u = 1/4 is +x, 1/2 is +z, 3/4 is -x), v = 0 is +y (the top row of
  the image) and v = 1 is -y.  A world direction w is taken to the local frame by the
  inverse of ``to_world`` (its linear part; a translation does not act on directions).
* **Radiance** ``eval(w)``: radiance arriving from direction w (w points from the receiver
  towards the map: Mitsuba's ``-si.wi``).  For an image of W x H pixels, pixel column i sits
  at u = (i + 1/2) / W and pixel row j at v = j / (H - 1): the first and last rows are
  the poles.  With ``x = frac(u - 1/(2W)) W``, ``i = min(floor x, W - 1)``,
  ``y = v (H - 1)``, ``j = min(floor y, H - 2)``, ``fx = x - i``, ``fy = y - j``:
  ``L = scale [(1 - fy) ((1 - fx) T[j, i] + fx T[j, i+1]) + fy ((1 - fx) T[j+1, i] +
  fx T[j+1, i+1])]`` with column W read as column 0 (wrap at the seam; no clamp needed in
  v, the poles are rows).  ``T`` is linear RGB: Mitsuba converts 8/16-bit (sRGB) images
  with the inverse sRGB curve and uses EXR values as stored, before any of this;
  ``EnvironmentMap`` takes the linear image (``vrlab.render.image.read_bitmap`` and
  ``srgb_decode`` produce it from a file as Mitsuba does).  ``scale`` multiplies the
  radiance only, not the sampling density.
* **Sampling weights.**  Luminance ``Y = 0.212671 R + 0.715160 G + 0.072169 B`` (Mitsuba's
  ``luminance``) per pixel; with ``mis_compensation`` (Karlik et al., "MIS Compensation:
  Optimizing Sampling Techniques in Multiple Importance Sampling", SIGGRAPH Asia 2019)
  ``Y <- max(Y - mean(Y), 0)`` with the plain mean over the W x H pixels (Mitsuba's choice,
  not weighted by solid angle), unless ``mean - min(Y) <= 0.01 mean`` (a near-constant map:
  no compensation).  Vertex weight ``q[j, i] = Y[j, i] sin(pi j / (H - 1))`` (exactly 0 on
  the pole rows), on the (H, W + 1) grid of vertices ``u_w = i / W``, ``v = j / (H - 1)``
  whose column W repeats column 0 (the seam): Mitsuba's ``Hierarchical2D`` data.
* **Density.**  As Mitsuba's warp, the uv density is **bilinear** inside each of the
  W x (H - 1) cells between pixel centres (``BilinearPiecewise2D(q)`` in the warp's
  coordinates ``(u_w, v)``, ``u_w = frac(u - 1/(2W))``): in cell (j, i) with
  ``s = u_w W - i``, ``t = v (H - 1) - j``,
  ``p_uv = [(1 - t) ((1 - s) q[j, i] + s q[j, i+1]) + t ((1 - s) q[j+1, i] + s q[j+1, i+1])]
  / mean(c)``, ``c[j, i]`` the mean of the cell's four vertex weights (its mass); since
  ``d(omega) = sin theta d(theta) d(phi) = 2 pi^2 sin theta du dv``,
  ``p(w) = p_uv(u_w, v) / (2 pi^2 sin theta)`` per steradian (Mitsuba's Jacobian), with
  ``sin theta`` clamped below at 2^-24 as Mitsuba clamps it (``dr::Epsilon<float>``).  So
  ``pdf`` equals Mitsuba's ``pdf_direction`` pointwise.  Towards the poles p_uv falls like
  sin theta (q is 0 on the pole rows), so p(w) stays bounded there.  It is zero where the
  four vertex weights of a cell vanish: with ``mis_compensation`` on all parts of the map
  dimmer than the mean (unbiased only under MIS with a technique that covers them).
* **Sampling.**  ``BilinearPiecewise2D`` picks a cell by its mass c (``table="alias"``: an
  alias table, O(1); ``"cdf"``: the marginal and conditional CDFs, O(log n), invertible), then
  inverts the cell's linear marginal in v and linear conditional in u exactly; the direction
  is ``latlong_direction(u_w + 1/(2W), v)``.  The map from uniforms to directions differs from
  Mitsuba's hierarchical one; the density is the same.

The ``constant`` emitter (src/emitters/constant.cpp) samples directions uniformly on the
sphere, pdf 1 / (4 pi): use ``vrlab.distributions.UniformSphere`` (Mitsuba's
``square_to_uniform_sphere(u)`` is ``UniformSphere().sample(u[..., ::-1])``: z = 1 - 2 u_y).

Checked at construction (``TypeError`` / ``ValueError`` naming the argument): ``image``
(H, W, 3) finite, >= 0, W >= 2, H >= 3 (Mitsuba's minimum), not all of zero sampling weight;
``to_world`` 3x3 or affine 4x4 whose linear part is orthogonal (within 1e-5; re-orthonormalised);
``scale`` finite >= 0; ``mis_compensation`` a bool; ``table`` one of ``TABLES``.  ``sample``,
``pdf``, ``eval``, ``uv`` and ``direction`` check only shapes (hot path).
"""
from __future__ import annotations

from typing import Any

import numpy as np

from .. import checks
from ..checks import describe as _describe
from ..colour import LUMINANCE
from .base import Distribution, as_float, as_points
from .bilinear import BilinearPiecewise2D

__all__ = ["EnvironmentMap", "MITSUBA_LUMINANCE", "SIN_THETA_MIN", "TABLES", "latlong_direction", "latlong_uv"]

#: Mitsuba 3's ``luminance(rgb)`` weights (include/mitsuba/core/spectrum.h, linear sRGB): vrlab.colour's
MITSUBA_LUMINANCE = tuple(LUMINANCE.tolist())
#: The floor of sin(theta) in the Jacobian (Mitsuba's ``dr::Epsilon<float>``, 2^-24).
SIN_THETA_MIN = 2.0 ** -24
TABLES = ("alias", "cdf")   # the cell choice of ``BilinearPiecewise2D``
_INV_2PI2 = 1.0 / (2.0 * np.pi ** 2)
_ONE_MINUS = float(np.nextafter(1.0, 0.0))


def latlong_uv(d: np.ndarray) -> np.ndarray:
    """Lat-long coordinates ``(u, v) (..., 2)`` of local directions ``d (..., 3)`` (+y up;
    any length): ``u = atan2(x, -z) / (2 pi)`` in [0, 1), ``v = atan2(hypot(x, z), y) / pi``
    in [0, 1] (= acos(y) / pi for unit d; Mitsuba 3 convention, src/emitters/envmap.cpp)."""
    d = as_points(d, 3, "d")
    u = np.arctan2(d[..., 0], -d[..., 2]) * (0.5 / np.pi)
    u = np.where(u < 0.0, u + 1.0, u)
    u = np.where(u >= 1.0, 0.0, u)
    v = np.arctan2(np.hypot(d[..., 0], d[..., 2]), d[..., 1]) * (1.0 / np.pi)
    return np.stack([u, v], -1)


def latlong_direction(uv: np.ndarray) -> np.ndarray:
    """Local unit directions of lat-long coordinates ``uv (..., 2)``: theta = pi v,
    phi = 2 pi u, d = (sin phi sin theta, cos theta, -cos phi sin theta) (Mitsuba 3
    convention, src/emitters/envmap.cpp; u is periodic)."""
    uv = as_points(uv, 2, "uv")
    theta, phi = np.pi * uv[..., 1], 2.0 * np.pi * uv[..., 0]
    st = np.sin(theta)
    return np.stack([np.sin(phi) * st, np.cos(theta), -np.cos(phi) * st], -1)


def _image(image: Any) -> np.ndarray:
    """``image`` as a float64 (H, W, 3) array of finite values >= 0, W >= 2, H >= 3."""
    try:
        a = np.array(as_float(image, "image"), dtype=np.float64)
    except TypeError:
        raise TypeError(f"image must be an (H, W, 3) array of linear RGB values, got {_describe(image)}") from None
    if a.ndim != 3 or a.shape[2] != 3:
        raise ValueError(f"image: expected linear RGB of shape (H, W, 3), got shape {a.shape}")
    h, w = a.shape[:2]
    if w < 2 or h < 3:
        raise ValueError(f"image: an environment map needs at least 2 x 3 pixels (W x H), got {w} x {h}")
    for bad, what in ((~np.isfinite(a), "a non-finite value"), (a < 0, "a negative value")):
        if bad.any():
            where = tuple(int(i) for i in np.argwhere(bad)[0])
            raise ValueError(f"image: {what} at index {where} ({a[where]}); radiance must be finite and >= 0")
    return a


def _rotation(to_world: Any) -> np.ndarray:
    """The orthogonal linear part of a 3x3 or affine 4x4 ``to_world`` (None: identity),
    re-orthonormalised (polar decomposition) so that its inverse is its transpose."""
    if to_world is None:
        return np.eye(3)
    m = checks.finite_array(to_world, "to_world")
    if m.shape == (4, 4):
        if not np.allclose(m[3], [0.0, 0.0, 0.0, 1.0], rtol=0.0, atol=1e-9):
            raise ValueError(f"to_world: a 4x4 matrix must be affine (last row 0 0 0 1), got {m[3].tolist()}")
        m = m[:3, :3]
    elif m.shape != (3, 3):
        raise ValueError(f"to_world: expected a 3x3 or 4x4 matrix, got shape {m.shape}")
    if not np.allclose(m.T @ m, np.eye(3), rtol=0.0, atol=1e-5):
        sv = np.linalg.svd(m, compute_uv=False)
        raise ValueError("to_world: the linear part must be a rotation (orthogonal, R^T R = I); Mitsuba's envmap "
                         "would distort the map under a scale or shear; got singular values "
                         f"{np.round(sv, 6).tolist()}")
    uu, _, vt = np.linalg.svd(m)
    return uu @ vt


def _apply(m: np.ndarray, d: np.ndarray) -> np.ndarray:
    """``m @ d`` for vectors ``d (..., 3)``, written out elementwise (no BLAS: the same
    bits in every process)."""
    return np.stack([m[k, 0] * d[..., 0] + m[k, 1] * d[..., 1] + m[k, 2] * d[..., 2] for k in range(3)], -1)


class EnvironmentMap(Distribution):
    """Mitsuba 3's ``envmap``: radiance ``eval(w)`` and importance sampling of directions
    (measure: solid angle) with Mitsuba's piecewise-bilinear density; formulas in the module
    docstring.

    ``EnvironmentMap(image, to_world=None, scale=1.0, mis_compensation=False, table="alias")``
    with ``image`` (H, W, 3) linear RGB (row 0 = top = +y).  ``sample(u (..., 2)) -> w (..., 3)``
    (world, unit), ``pdf(w) = p_uv / (2 pi^2 sin theta)`` sr^-1, ``sample_pdf(u)``,
    ``eval(w) -> (..., 3)``, ``uv(w) -> (..., 2)``, ``direction(uv) -> (..., 3)``; ``invert(w)``
    only with ``table="cdf"`` (an alias table is not a bijection: ``hasattr`` is False).
    Attributes: ``image``, ``width`` W, ``height`` H, ``rotation`` (3x3), ``scale``,
    ``luminance`` (H, W) after compensation, ``vertex_weights`` (H, W + 1) q, ``weights``
    (H - 1, W) cell masses ``c``, ``warp`` (the ``BilinearPiecewise2D`` of q in ``(u_w, v)``),
    ``offset`` (the subtracted mean, 0 without compensation).
    """

    dim_u = 2
    dim_x = 3
    measure = "solid angle"

    def __init__(self, image: Any, to_world: Any = None, scale: float = 1.0, mis_compensation: bool = False,
                 table: str = "alias"):
        self.image = _image(image)
        self.height, self.width = self.image.shape[:2]
        self.rotation = _rotation(to_world)
        self._identity = bool(np.array_equal(self.rotation, np.eye(3)))
        self.scale = checks.real(scale, "scale", low=0.0)
        self.mis_compensation = checks.flag(mis_compensation, "mis_compensation")
        self.table = checks.choice(table, "table", TABLES)
        lum = self.image @ LUMINANCE
        self.offset = 0.0
        if self.mis_compensation:
            mean = float(lum.mean())
            if mean - float(lum.min()) > 0.01 * mean:   # else a near-constant map: no compensation
                self.offset = mean
                lum = np.maximum(lum - mean, 0.0)
        self.luminance = lum
        h, w = self.height, self.width
        rows = np.arange(h)
        sin_rows = np.sin(np.pi * np.minimum(rows, h - 1 - rows) / (h - 1))   # exactly 0 at both poles
        q = lum * sin_rows[:, None]
        if not q.sum() > 0:
            raise ValueError("image: the sampling weights (luminance x sin theta) are all zero: the map is black "
                             "(or lit only on its first and last rows, the poles, where sin theta = 0)")
        self.vertex_weights = np.concatenate([q, q[:, :1]], axis=1)   # column W is column 0 (the seam)
        try:
            self.warp = BilinearPiecewise2D(self.vertex_weights, table=self.table)  # x = u_w, y = v on [0, 1]^2
        except ValueError as exc:   # only for weights at the edge of float range
            raise ValueError(f"image: its sampling weights cannot be tabulated ({exc})") from None
        self.weights = self.warp.masses                  # (H - 1, W): mean of each cell's 4 vertex weights
        self._half = 0.5 / w

    # -- mapping -----------------------------------------------------------------------------
    def _to_local(self, w: np.ndarray) -> np.ndarray:
        w = w.astype(np.float64, copy=False)
        return w if self._identity else _apply(self.rotation.T, w)

    def _to_world(self, d: np.ndarray) -> np.ndarray:
        return d if self._identity else _apply(self.rotation, d)

    def uv(self, w: np.ndarray) -> np.ndarray:
        """Lat-long ``(u, v) (..., 2)`` of world directions ``w (..., 3)``: ``latlong_uv`` of
        ``to_world^-1 w``; u in [0, 1) (0 = local -z, 1/4 = local +x), v in [0, 1] (0 = local +y)."""
        return latlong_uv(self._to_local(as_points(w, 3, "w")))

    def direction(self, uv: np.ndarray) -> np.ndarray:
        """World unit directions ``to_world latlong_direction(uv)`` of ``uv (..., 2)``."""
        return self._to_world(latlong_direction(as_points(uv, 2, "uv").astype(np.float64, copy=False)))

    # -- radiance ----------------------------------------------------------------------------
    def eval(self, w: np.ndarray) -> np.ndarray:
        """Radiance ``(..., 3)`` arriving from world directions ``w (..., 3)`` (pointing away
        from the receiver): Mitsuba's bilinear lookup (pixel centres at u = (i + 1/2) / W,
        rows at v = j / (H - 1), wrap in u) times ``scale``."""
        uv = self.uv(w)
        wd, ht = self.width, self.height
        x = np.mod(uv[..., 0] - self._half, 1.0) * wd
        y = uv[..., 1] * (ht - 1)
        i = np.fmin(np.fmax(np.floor(x), 0), wd - 1).astype(np.intp)   # fmax/fmin: NaN -> 0 (NaN radiance)
        j = np.fmin(np.fmax(np.floor(y), 0), ht - 2).astype(np.intp)
        fx, fy = x - i, y - j
        i1 = np.where(i + 1 == wd, 0, i + 1)
        texels = self.image.reshape(-1, 3)                # a pixel's 3 channels: one gather
        r0 = j * wd
        r1 = r0 + wd
        c00, c01 = np.take(texels, r0 + i, axis=0), np.take(texels, r0 + i1, axis=0)
        c10, c11 = np.take(texels, r1 + i, axis=0), np.take(texels, r1 + i1, axis=0)
        gx, gy = 1.0 - fx, 1.0 - fy
        out = np.empty(uv.shape[:-1] + (3,))
        for k in range(3):                                # per channel: no length-3 broadcasting
            top = gx * c00[..., k] + fx * c01[..., k]
            bottom = gx * c10[..., k] + fx * c11[..., k]
            out[..., k] = self.scale * (gy * top + fy * bottom)
        return out

    # -- sampling ----------------------------------------------------------------------------
    def sample_pdf(self, u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``(w, pdf)``: world directions ``(..., 3)`` for uniforms ``u (..., 2)`` and their
        density per steradian, ``p_uv / (2 pi^2 max(sin theta, 2^-24))`` (p_uv of the sampled
        warp point, bilinear in its cell)."""
        xw, p_uv = self.warp.sample_pdf(u)
        uv = np.stack([xw[..., 0] + self._half, xw[..., 1]], -1)    # u may pass 1: phi is periodic
        sin_theta = np.maximum(np.sin(np.pi * xw[..., 1]), SIN_THETA_MIN)
        return self.direction(uv), p_uv * _INV_2PI2 / sin_theta

    def sample(self, u: np.ndarray) -> np.ndarray:
        """World unit directions ``(..., 3)`` for uniforms ``u (..., 2)``: the warp point
        ``(u_w, v) = warp.sample(u)`` (a cell by the table, alias: ``u_1`` picks the cell; cdf:
        ``u_2`` the row, ``u_1`` the column; then the bilinear patch), ``u = u_w + 1/(2W)``."""
        return self.sample_pdf(u)[0]

    def _warp_coords(self, w: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Warp coordinates ``(u_w, v)`` and sin theta of world directions ``w``."""
        d = self._to_local(as_points(w, 3, "w"))
        uv = latlong_uv(d)
        r = np.hypot(d[..., 0], d[..., 2])
        n = np.sqrt(r * r + d[..., 1] * d[..., 1])
        sin_theta = np.maximum(r / np.where(n > 0, n, 1.0), SIN_THETA_MIN)
        uw = np.mod(uv[..., 0] - self._half, 1.0)
        return np.stack([np.minimum(uw, _ONE_MINUS), uv[..., 1]], -1), sin_theta

    def pdf(self, w: np.ndarray) -> np.ndarray:
        """Density per steradian of world directions ``w (..., 3)``:
        ``p(w) = p_uv(u_w, v) / (2 pi^2 max(sin theta, 2^-24))`` (d omega = 2 pi^2 sin theta du dv)."""
        xw, sin_theta = self._warp_coords(w)
        return self.warp.pdf(xw) * _INV_2PI2 / sin_theta

    def _invert(self, w: np.ndarray) -> np.ndarray:
        xw, _ = self._warp_coords(w)
        return self.warp.invert(xw)

    @property
    def invert(self):
        """``invert(w) -> u (..., 2)``, the uniforms that ``sample`` maps to ``w`` (``table="cdf"``
        only: ``warp.invert`` of the direction's warp point)."""
        if self.table != "cdf":
            raise AttributeError("invert: an alias table is not a bijection; build with table='cdf' to invert")
        return self._invert

    def _repr_fields(self) -> dict:
        return {"shape": self.image.shape, "scale": self.scale, "mis_compensation": self.mis_compensation,
                "table": self.table, "rotated": not self._identity}
