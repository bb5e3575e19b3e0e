"""Mitsuba 3's pixel reconstruction filters as warps of sub-pixel offsets.  Measure: area.

What a pixel is in Mitsuba 3.  The film adds every image-plane sample x_i (uniform in the
film, ``hdrfilm``'s default ``sample_border=false``) to each pixel c whose centre lies within
the filter radius, with weight w(c - x_i), and divides by the summed weights at the end:
pixel c = sum_i w(c - x_i) L(x_i) / sum_i w(c - x_i) (src/render/imageblock.cpp ``put``,
src/films/hdrfilm.cpp).  As the sample count grows this tends to

    E_c = int w(x - c) L(x) dx / int w(x - c) dx,    w(x, y) = w1(x) w1(y)

(integrals over the film: an edge pixel's filter is cut at the film's edge; the filters here
are symmetric, w(-d) = w(d)).  Sampling offsets d = x - c with density w(d) / int w and
averaging L(c + d) estimates E_c without bias; :meth:`ReconstructionFilter.window` gives the
same density cut to the film for edge pixels.

The 1D filters w1 (Mitsuba 3.9.1, src/rfilters/*.cpp, include/mitsuba/core/rfilter.h):

* ``box``: w1 = 1 on [-1/2, 1/2), radius 1/2, no parameters.  ImageBlock drops a box filter
  and adds each sample to the pixel containing it: the same weights.
* ``tent`` (``radius``, default 1): w1 = max(0, 1 - |x| / radius).
* ``gaussian`` (``stddev``, default 0.5): radius = 4 stddev, w1(x) = max(0, g(x^2/s^2) -
  g(16)), g(t) = sum_i c_i t^i the degree-9 minimax (Remez) fit of exp(-t/2) on [0, 16]
  whose coefficients are listed in gaussian.cpp (``_REMEZ`` below).  The value at the radius
  *is* subtracted, so w1(radius) = 0.  (CUDA variants evaluate exp(-x^2/(2 s^2)) - exp(-8)
  instead, at most 4e-4 from g; g - g(16) has no other real zero, so w1 = 0 beyond the radius.)
* Negative-lobed filters (``mitchell``, ``catmullrom``, ``lanczos``) are not densities:
  ImageBlock weighs every pixel within the radius by them, negative weights included, and
  the film divides by the signed sum.  They are not provided here.

Discretisation.  The scalar variants' ImageBlock weighs by ``eval_discretized``, not ``eval``:
w1 tabulated at MI_FILTER_RESOLUTION = 31 points, w_d(x) = w1(r k / 31) with
k = min(floor(31 |x| / r), 31) and w1(r) := 0, a step function of |x| (62 steps on [-r, r]).
The JIT variants (llvm, cuda) use w1 itself.  So the expected image of ``scalar_rgb`` (vrlab's
references) is w_d's: ``discretized=True`` (default) samples w_d exactly by inverting its
piecewise-constant CDF (``PiecewiseConstant1D`` on [0, r], mirrored); ``discretized=False``
samples w1 exactly: box and tent by their closed-form inverse CDFs, the gaussian by inverting
the CDF of its polynomial (which integrates in closed form, sum_i c_i s^(2i+1) / (2i + 1))
with bracketed Newton steps.  No fitted table: the filter *is* Mitsuba's table or polynomial.

Every filter is a 2D distribution of offsets (pixel units): ``sample(u) -> (..., 2)``,
``pdf(x) -> (...)`` (area), ``invert(x) -> u``, ``eval(x)`` = w(x) (unnormalised), and the
1D pieces ``eval1`` (Mitsuba's ``eval``), ``eval1_discretized`` (``eval_discretized``),
``weight1`` (the one the film uses), ``sample1``, ``pdf1``, ``cdf1`` on plain arrays.
Constructors check their arguments; ``sample``/``pdf``/``invert`` check shapes only.
"""
from __future__ import annotations

from typing import Any

import numpy as np

from .. import checks
from .base import Distribution, as_float, as_points, as_uniforms, positive_float
from .tabulated import PiecewiseConstant1D

__all__ = ["BoxFilter", "FILTERS", "FilterWindow", "GaussianFilter", "MI_FILTER_RESOLUTION",
           "ReconstructionFilter", "TentFilter"]

#: Mitsuba 3's filter table size (include/mitsuba/core/rfilter.h).
MI_FILTER_RESOLUTION = 31

#: Minimax fit of exp(-t/2) on t in [0, 16], degree 9 (Mitsuba 3, src/rfilters/gaussian.cpp).
_REMEZ = np.array([9.992604880e-1, -4.977025247e-1, 1.222248550e-1, -1.932406282e-2, 2.136713061e-3,
                   -1.679873860e-4, 9.202145248e-6, -3.329417433e-7, 7.128382794e-9, -6.821193280e-11])
_NEWTON_STEPS = 100  # enough for bisection alone to reach float64 resolution on [0, r]


class ReconstructionFilter(Distribution):
    """A separable pixel filter w(x, y) = w1(x) w1(y) as the density of sub-pixel offsets.

    p(x) = w(x) / (int w1)^2 (area, pixel units) on [-r, r]^2, w1 the film's weight
    (``weight1``: Mitsuba's ``eval_discretized`` if ``discretized``, else its ``eval``; module
    docstring).  Sampling inverts the 1D CDF on each axis: ``sample1`` folds u to
    t = |2u - 1|, samples |x| on [0, r] by inversion and takes the sign of 2u - 1, so the
    map is monotone and ``invert`` (= ``cdf1`` per axis) undoes it.
    """

    dim_u = 2
    dim_x = 2
    measure = "area"
    plugin = ""

    def _setup(self, radius: float, discretized: Any) -> None:
        self.radius = float(radius)
        self.discretized = checks.flag(discretized, "discretized")
        #: Mitsuba's ``m_values``: w1 at r k / 31, k = 0..30 (its entry 31, = 0, is implied).
        self.table = self.eval1(self.radius * np.arange(MI_FILTER_RESOLUTION) / MI_FILTER_RESOLUTION)
        self._steps = np.append(self.table, 0.0)
        if self.discretized:
            self._half = PiecewiseConstant1D(self.table, (0.0, self.radius))
            self.integral1 = 2.0 * self.radius / MI_FILTER_RESOLUTION * float(self.table.sum())
        else:
            self.integral1 = 2.0 * self._half_integral()

    # -- 1D pieces (subclasses: eval1, _half_integral, _half_cdf, _half_inverse)

    def eval1(self, x: Any) -> np.ndarray:  # pragma: no cover - interface
        """Mitsuba's ``ReconstructionFilter::eval(x)`` (continuous 1D weight)."""
        raise NotImplementedError  # abstract

    def eval1_discretized(self, x: Any) -> np.ndarray:
        """Mitsuba's ``eval_discretized(x)``: table[min(floor(31 |x| / r), 31)], table[31] = 0."""
        k = np.floor(np.abs(as_float(x, "x")) * (MI_FILTER_RESOLUTION / self.radius))
        k = np.where(k < MI_FILTER_RESOLUTION, k, MI_FILTER_RESOLUTION)    # also NaN and inf: weight 0
        return self._steps[k.astype(np.intp)]

    def weight1(self, x: Any) -> np.ndarray:
        """The 1D weight the film applies: ``eval1_discretized`` if ``discretized``, else
        ``eval1`` on [-r, r] (ImageBlock visits only pixels whose centre is within r)."""
        if self.discretized:
            return self.eval1_discretized(x)
        x = as_float(x, "x")
        return np.where(np.abs(x) <= self.radius, self.eval1(x), 0.0)

    def pdf1(self, x: Any) -> np.ndarray:
        """1D density (length): weight1(x) / integral1, integral1 = int w1."""
        return self.weight1(x) / self.integral1

    def cdf1(self, x: Any) -> np.ndarray:
        """1D CDF: 1/2 + sign(x) A(min(|x|, r)) / 2, A(a) = int_0^a w1 / int_0^r w1."""
        x = as_float(x, "x")
        return 0.5 + 0.5 * np.sign(x) * self._cdf_half(np.minimum(np.abs(x), self.radius))

    def sample1(self, u: Any) -> np.ndarray:
        """1D inverse CDF: x = sign(2u - 1) A^-1(|2u - 1|) (any array shape)."""
        s = 2.0 * as_float(u, "u") - 1.0
        return np.sign(s) * self._inverse_half(np.abs(s))

    def _cdf_half(self, a: np.ndarray) -> np.ndarray:
        if self.discretized:
            return self._half.invert(a[..., None])[..., 0]
        return self._half_cdf(a)

    def _inverse_half(self, t: np.ndarray) -> np.ndarray:
        if self.discretized:
            return self._half.sample(t[..., None])[..., 0]
        return self._half_inverse(t)

    # -- the 2D distribution

    def eval(self, x: Any) -> np.ndarray:
        """w(x) = weight1(x_1) weight1(x_2) (unnormalised), offsets ``x`` of shape (..., 2)."""
        x = as_points(x, 2)
        return self.weight1(x[..., 0]) * self.weight1(x[..., 1])

    def sample(self, u):
        return self.sample1(as_uniforms(u, 2))

    def pdf(self, x):
        return self.eval(x) / (self.integral1 * self.integral1)

    def invert(self, x):
        return self.cdf1(as_points(x, 2))

    def window(self, lo: Any, hi: Any) -> "FilterWindow":
        """These offsets restricted to the box [lo, hi] (e.g. film - pixel centre); see
        :class:`FilterWindow`."""
        return FilterWindow(self, lo, hi)

    def _repr_fields(self):
        return {"radius": self.radius, "discretized": self.discretized}


class BoxFilter(ReconstructionFilter):
    """Mitsuba's ``box``: w1 = 1 on [-r, r), r = 1/2 (src/rfilters/box.cpp; Mitsuba's box has
    no parameter, other radii are a vrlab extension).  Offsets are uniform on the square:
    A(a) = a / r.  ``radius``: a finite real > 0; ``discretized``: True or False (same filter)."""

    plugin = "box"

    def __init__(self, radius: float = 0.5, discretized: bool = True):
        self._setup(positive_float(radius, "radius"), discretized)

    def eval1(self, x):
        x = as_float(x, "x")
        return np.where((x >= -self.radius) & (x < self.radius), 1.0, 0.0)

    def _half_integral(self):
        return self.radius

    def _half_cdf(self, a):
        return a / self.radius

    def _half_inverse(self, t):
        return self.radius * t


class TentFilter(ReconstructionFilter):
    """Mitsuba's ``tent``: w1 = max(0, 1 - |x| / r), ``radius`` r default 1 (src/rfilters/tent.cpp).

    Continuous: int w1 = r, A(a) = (a/r)(2 - a/r), A^-1(t) = r t / (1 + sqrt(1 - t))
    (cancellation-free).  Discretised: int w_d = 2 r / 31 sum_k (1 - k/31) = 32 r / 31.
    ``radius``: a finite real > 0; ``discretized``: True or False.
    """

    plugin = "tent"

    def __init__(self, radius: float = 1.0, discretized: bool = True):
        self._setup(positive_float(radius, "radius"), discretized)

    def eval1(self, x):
        return np.maximum(0.0, 1.0 - np.abs(as_float(x, "x")) / self.radius)

    def _half_integral(self):
        return 0.5 * self.radius

    def _half_cdf(self, a):
        s = a / self.radius
        return s * (2.0 - s)

    def _half_inverse(self, t):
        return self.radius * t / (1.0 + np.sqrt(np.maximum(1.0 - t, 0.0)))


class GaussianFilter(ReconstructionFilter):
    """Mitsuba's ``gaussian``: radius r = 4 ``stddev`` (default 0.5), w1(x) = max(0, g(x^2/s^2) - g(16))
    with g Mitsuba's Remez polynomial for exp(-t/2) (src/rfilters/gaussian.cpp; module docstring).

    Continuous sampling: with c'_i the coefficients after subtracting g(16),
    G(a) = s sum_i c'_i (a/s)^(2i+1) / (2i+1) = int_0^a w1, A(a) = G(a) / G(r); A^-1 by
    Newton steps on G(a) = t G(r) (G' = w1 >= 0) kept inside a bisection bracket, from the
    truncated normal's quantile s sqrt(2) erfinv(t erf(2 sqrt(2))), until the step or the
    bracket is below 4 ulp of r.  ``stddev``: a finite real > 0; ``discretized``: True or False.
    """

    plugin = "gaussian"

    def __init__(self, stddev: float = 0.5, discretized: bool = True):
        self.stddev = positive_float(stddev, "stddev")
        self._c = _REMEZ.copy()
        self._c[0] -= np.polynomial.polynomial.polyval(16.0, _REMEZ)   # w1(r) = 0
        self._ci = self._c / (2.0 * np.arange(len(self._c)) + 1.0)      # odd antiderivative
        self._setup(4.0 * self.stddev, discretized)

    def eval1(self, x):
        z = as_float(x, "x") / self.stddev
        return np.maximum(np.polynomial.polynomial.polyval(z * z, self._c), 0.0)

    def _G(self, a):
        z = a / self.stddev
        return self.stddev * z * np.polynomial.polynomial.polyval(z * z, self._ci)

    def _half_integral(self):
        return float(self._G(self.radius))

    def _half_cdf(self, a):
        return self._G(a) / self._G(self.radius)

    def _half_inverse(self, t):
        from scipy.special import erf, erfinv  # imported on use (startup time)

        t = np.asarray(t, dtype=np.float64)
        r, s = self.radius, self.stddev
        target = t * self._G(r)
        x = np.clip(s * np.sqrt(2.0) * erfinv(t * erf(2.0 * np.sqrt(2.0))), 0.0, r).ravel()
        lo, hi = np.zeros_like(x), np.full_like(x, r)
        y = target.ravel()
        todo = np.arange(x.size)
        tol = 4.0 * np.finfo(np.float64).eps * r
        for _ in range(_NEWTON_STEPS):
            xa = x[todo]
            f = self._G(xa) - y[todo]
            la = np.where(f < 0.0, xa, lo[todo])
            ha = np.where(f > 0.0, xa, hi[todo])
            with np.errstate(divide="ignore", invalid="ignore"):
                xn = xa - f / self.eval1(xa)
            xn = np.where((xn > la) & (xn < ha), xn, 0.5 * (la + ha))   # NaN steps bisect too
            x[todo], lo[todo], hi[todo] = np.where(f == 0.0, xa, xn), la, ha
            todo = todo[(np.abs(xn - xa) > tol) & (ha - la > tol) & (f != 0.0)]
            if todo.size == 0:
                break
        return x.reshape(t.shape)

    def _repr_fields(self):
        return {"stddev": self.stddev, "discretized": self.discretized}


#: Mitsuba plugin name -> class, for the filters that are densities.
FILTERS = {"box": BoxFilter, "tent": TentFilter, "gaussian": GaussianFilter}


class FilterWindow(Distribution):
    """A filter's offsets restricted to the box [lo, hi]: p(x) = w(x) / (int_[lo,hi] w) (area).

    For an edge pixel c of a W x H film, lo = -c and hi = (W, H) - c: the offsets that stay on
    the film, whose filter Mitsuba cuts there (module docstring).  Per axis the CDF is
    rescaled, u' = F(lo) + u (F(hi) - F(lo)), x = F^-1(u'); ``mass`` = prod (F(hi) - F(lo))
    is the share of the filter's weight inside.  ``lo`` and ``hi`` have shape (..., 2)
    (leading axes broadcast with the uniforms'), entries may be -inf / inf.  Checked: real
    numbers, no NaN, lo < hi, and each axis overlaps the filter's support.
    """

    dim_u = 2
    dim_x = 2
    measure = "area"

    def __init__(self, filt: ReconstructionFilter, lo: Any, hi: Any):
        if not isinstance(filt, ReconstructionFilter):
            raise TypeError(f"filt must be a ReconstructionFilter, got {checks.describe(filt)}")
        self.filter = filt
        self.lo, self.hi = as_points(lo, 2, "lo", finite=False), as_points(hi, 2, "hi", finite=False)
        for a, name in ((self.lo, "lo"), (self.hi, "hi")):
            if np.isnan(a).any():
                raise ValueError(f"{name}: must not contain NaN")
        if not np.all(self.lo < self.hi):
            raise ValueError("lo, hi: need lo < hi on both axes")
        self._flo, self._fhi = filt.cdf1(self.lo), filt.cdf1(self.hi)
        self._mass1 = self._fhi - self._flo
        if not np.all(self._mass1 > 0):
            raise ValueError(f"lo, hi: the window must overlap the filter's support (-{filt.radius:g}, "
                             f"{filt.radius:g}) on both axes")
        self.mass = np.prod(self._mass1, axis=-1)
        r = filt.radius
        self._clip = (np.maximum(self.lo, -r), np.minimum(self.hi, r))

    def sample(self, u):
        u = as_uniforms(u, 2)
        x = self.filter.sample1(self._flo + u * self._mass1)
        return np.clip(x, *self._clip)

    def pdf(self, x):
        x = as_points(x, 2)
        inside = np.all((x >= self.lo) & (x <= self.hi), -1)
        return np.where(inside, self.filter.pdf(x) / self.mass, 0.0)

    def invert(self, x):
        return (self.filter.cdf1(as_points(x, 2)) - self._flo) / self._mass1

    def _repr_fields(self):
        return {"filter": self.filter, "lo": self.lo.tolist(), "hi": self.hi.tolist()}
