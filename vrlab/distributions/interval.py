"""One-dimensional (and box) warps.  Measure: length (volume for boxes).

Points of a k-dimensional domain have shape ``(..., k)``, also for k = 1.

* ``UniformBox(bounds)``: x = a + (b - a) u, p = 1 / volume.
* ``LinearInterval(a, b, f0, f1)``: p proportional to the line from f0 at a to f1
  at b; inverting F(t) = (f0 t + (f1 - f0) t^2 / 2) / ((f0 + f1) / 2) gives the
  cancellation-free root t = u (f0 + f1) / (f0 + sqrt((1 - u) f0^2 + u f1^2)).
  With f0 = 0, f1 = 1 on [0, pi/2] this is the lecture's p(x) = 8 x / pi^2
  (Russian lecture 4, "importance sampling of sin x").
* ``Exponential(rate, upper=None)``: p = rate e^(-rate x) on [0, inf), or truncated
  to [0, upper] (divide by 1 - e^(-rate upper)); x = -log(1 - u c) / rate.
"""
from __future__ import annotations

from typing import Any, Sequence

import numpy as np

from .. import checks
from .base import Distribution, as_float, as_points, as_uniforms, distribution_list, positive_float


def as_bounds(bounds, name: str = "bounds") -> np.ndarray:
    """Bounds of a box as a (k, 2) float64 array, checked: ``TypeError`` unless numbers,
    ``ValueError`` unless shape (k, 2) (or (2,)), k >= 1, finite, a < b with b - a finite."""
    b = np.array(as_float(bounds, name), dtype=np.float64)
    if b.ndim == 1 and b.shape == (2,):
        b = b[None, :]
    if b.ndim != 2 or b.shape[1] != 2 or b.shape[0] == 0:
        raise ValueError(f"{name}: expected [(a1, b1), (a2, b2), ...], got shape {b.shape}: {bounds!r}")
    if not np.all(np.isfinite(b)):
        raise ValueError(f"{name}: every interval must be finite, got {b.tolist()}")
    if not np.all(b[:, 1] > b[:, 0]):
        k = int(np.argmax(~(b[:, 1] > b[:, 0])))
        raise ValueError(f"{name}: every interval needs a < b, but interval {k} is {tuple(b[k].tolist())}")
    with np.errstate(over="ignore"):
        if not np.all(np.isfinite(b[:, 1] - b[:, 0])):
            raise ValueError(f"{name}: every interval must have a finite length b - a, got {b.tolist()}")
    return b


class UniformBox(Distribution):
    """Uniform on the box ``[(a1, b1), ..., (ak, bk)]``; p = 1 / prod(b - a) (length/area/volume).

    ``bounds`` is checked by :func:`as_bounds` (and the volume must be finite and > 0)."""

    measure = "volume"

    def __init__(self, bounds: Sequence):
        b = as_bounds(bounds)
        self.lo, self.hi = b[:, 0], b[:, 1]
        self.dim_u = self.dim_x = len(b)
        with np.errstate(over="ignore", under="ignore"):
            self.volume = float(np.prod(self.hi - self.lo))
        if not (np.isfinite(self.volume) and self.volume > 0):
            raise ValueError(f"bounds: the box volume {self.volume} is not a finite number > 0 (over- or underflow)")
        self.measure = {1: "length", 2: "area"}.get(self.dim_x, "volume")

    def sample(self, u):
        return self.lo + (self.hi - self.lo) * as_uniforms(u, self.dim_u)

    def pdf(self, x):
        x = as_points(x, self.dim_x)
        inside = np.all((x >= self.lo) & (x <= self.hi), -1)
        return np.where(inside, 1.0 / self.volume, 0.0)

    def invert(self, x):
        return (as_points(x, self.dim_x) - self.lo) / (self.hi - self.lo)

    def _repr_fields(self):
        return {"bounds": np.stack([self.lo, self.hi], 1).tolist()}


def _interval(a: Any, b: Any) -> tuple[float, float]:
    """Finite reals a < b with b - a finite, else an error naming ``a`` and ``b``."""
    a, b = checks.real(a, "a"), checks.real(b, "b")
    if not a < b:
        raise ValueError(f"a, b: need a < b, got a={a:g}, b={b:g}")
    if not np.isfinite(b - a):
        raise ValueError(f"a, b: the length b - a overflows, got a={a:g}, b={b:g}")
    return a, b


def UniformInterval(a: float = 0.0, b: float = 1.0) -> UniformBox:
    """Uniform on [a, b]: p = 1 / (b - a) (length); a < b finite reals."""
    return UniformBox([_interval(a, b)])


class LinearInterval(Distribution):
    """Density on [a, b] proportional to the linear function from f0 (at a) to f1 (at b).

    p(x) = 2 ((1 - t) f0 + t f1) / ((f0 + f1)(b - a)), t = (x - a) / (b - a) (length).
    Checked: a < b finite reals, f0, f1 finite reals >= 0, not both zero.
    """

    dim_u = dim_x = 1
    measure = "length"

    def __init__(self, a: float = 0.0, b: float = 1.0, f0: float = 0.0, f1: float = 1.0):
        self.a, self.b = _interval(a, b)
        f0, f1 = checks.real(f0, "f0", low=0.0), checks.real(f1, "f1", low=0.0)
        if not (f0 + f1 > 0 and np.isfinite(f0 + f1)):
            raise ValueError(f"f0, f1 must be finite, >= 0 and not both zero, got {f0}, {f1}")
        self.f0, self.f1 = f0, f1

    def sample(self, u):
        u = as_uniforms(u, 1)[..., 0]
        f0, f1 = self.f0, self.f1
        denom = f0 + np.sqrt((1.0 - u) * f0 * f0 + u * f1 * f1)
        t = np.where(denom > 0, u * (f0 + f1) / np.where(denom > 0, denom, 1.0), 0.0)
        return (self.a + (self.b - self.a) * np.clip(t, 0.0, 1.0))[..., None]

    def pdf(self, x):
        x = as_points(x, 1)[..., 0]
        t = (x - self.a) / (self.b - self.a)
        p = 2.0 * ((1.0 - t) * self.f0 + t * self.f1) / ((self.f0 + self.f1) * (self.b - self.a))
        return np.where((t >= 0) & (t <= 1), p, 0.0)

    def invert(self, x):
        t = (as_points(x, 1)[..., 0] - self.a) / (self.b - self.a)
        return ((self.f0 * t + 0.5 * (self.f1 - self.f0) * t * t) * 2.0 / (self.f0 + self.f1))[..., None]

    def _repr_fields(self):
        return {"a": self.a, "b": self.b, "f0": self.f0, "f1": self.f1}


class Exponential(Distribution):
    """Exponential density rate e^(-rate x) on [0, inf), or truncated to [0, upper] (length).

    Checked: ``rate`` and ``upper`` (if given) finite reals > 0, with rate * upper > 0."""

    dim_u = dim_x = 1
    measure = "length"

    def __init__(self, rate: float = 1.0, upper: float | None = None):
        self.rate = positive_float(rate, "rate")
        self.upper = None if upper is None else positive_float(upper, "upper")
        # mass of [0, upper] under the untruncated density
        self._mass = 1.0 if self.upper is None else float(-np.expm1(-self.rate * self.upper))
        if not self._mass > 0:
            raise ValueError(f"rate, upper: the interval [0, upper] holds no mass (rate * upper underflows), "
                             f"got rate={self.rate:g}, upper={self.upper:g}")

    def sample(self, u):
        u = as_uniforms(u, 1)
        return -np.log1p(-u * self._mass) / self.rate

    def pdf(self, x):
        x = as_points(x, 1)[..., 0]
        inside = x >= 0 if self.upper is None else (x >= 0) & (x <= self.upper)
        return np.where(inside, self.rate * np.exp(-self.rate * np.where(inside, x, 0.0)) / self._mass, 0.0)

    def invert(self, x):
        return -np.expm1(-self.rate * as_points(x, 1)) / self._mass

    def _repr_fields(self):
        return {"rate": self.rate, "upper": self.upper}


class TruncatedNormal(Distribution):
    """Normal(mu, sigma) restricted to [a, b] (length), by inversion of the normal CDF.

    x = mu + sigma Phi^-1(Phi(alpha) + u (Phi(beta) - Phi(alpha))), alpha = (a - mu)/sigma,
    beta = (b - mu)/sigma; p(x) = phi((x - mu)/sigma) / (sigma (Phi(beta) - Phi(alpha))).
    An interval wholly right of mu (alpha > 0) is sampled as its mirror image, x = mu - sigma
    Phi^-1(Phi(-beta) + (1 - u) (Phi(-alpha) - Phi(-beta))) (still increasing in u): there Phi
    takes tiny values, which float64 holds to full relative precision, where 1 - Phi would
    round away (at alpha = 8 only 7 distinct samples were left).  So tails down to about 37
    sigma stay exact; p is computed as exp(-z^2/2 - log(sqrt(2 pi) sigma mass)).  Checked: mu
    finite, sigma finite > 0, a < b (either may be infinite, not NaN), and the interval must
    hold at least 1e-300 of the normal's mass.
    """

    dim_u = dim_x = 1
    measure = "length"
    MIN_MASS = 1e-300

    def __init__(self, mu: float = 0.0, sigma: float = 1.0, a: float = -np.inf, b: float = np.inf):
        from scipy import special

        self._sp = special
        self.mu = checks.real(mu, "mu")
        self.sigma = positive_float(sigma, "sigma")
        a, b = checks.real(a, "a", finite=False), checks.real(b, "b", finite=False)
        if not a < b:
            raise ValueError(f"a, b: need a < b, got a={a}, b={b}")
        self.a, self.b = a, b
        alpha, beta = (self.a - self.mu) / self.sigma, (self.b - self.mu) / self.sigma
        self._flip = bool(alpha > 0)                  # mirror a right tail into the left one
        lo, hi = (-beta, -alpha) if self._flip else (alpha, beta)
        self._lo, self._hi = special.ndtr(lo), special.ndtr(hi)
        self.mass = self._hi - self._lo
        if not self.mass >= self.MIN_MASS:
            raise ValueError(f"a, b: the interval holds {self.mass:.3g} of the normal's mass, below "
                             f"{self.MIN_MASS:g} (it lies about {min(abs(alpha), abs(beta)):.0f} sigma from mu), "
                             "too little for float64")
        self._log_norm = np.log(np.sqrt(2 * np.pi) * self.sigma * self.mass)

    def sample(self, u):
        u = as_uniforms(u, 1)
        if self._flip:
            return np.clip(self.mu - self.sigma * self._sp.ndtri(self._lo + (1.0 - u) * self.mass), self.a, self.b)
        return np.clip(self.mu + self.sigma * self._sp.ndtri(self._lo + u * self.mass), self.a, self.b)

    def pdf(self, x):
        x = as_points(x, 1)[..., 0]
        z = (x - self.mu) / self.sigma
        inside = (x >= self.a) & (x <= self.b)
        return np.where(inside, np.exp(-0.5 * z * z - self._log_norm), 0.0)

    def invert(self, x):
        z = (as_points(x, 1) - self.mu) / self.sigma
        if self._flip:
            return 1.0 - (self._sp.ndtr(-z) - self._lo) / self.mass
        return (self._sp.ndtr(z) - self._lo) / self.mass

    def _repr_fields(self):
        return {"mu": self.mu, "sigma": self.sigma, "a": self.a, "b": self.b}


class Product(Distribution):
    """Independent coordinates: x = (x_1, ..., x_m) with x_j ~ components[j];
    p(x) = prod_j p_j(x_j) (product measure).  Uniforms are split in order.
    Checked: ``components`` is a non-empty list of distributions with integer ``dim_x``."""

    def __init__(self, components):
        self.components = distribution_list(components)
        for j, c in enumerate(self.components):
            checks.integer(getattr(c, "dim_x", None), f"components[{j}].dim_x", low=1)
        self.dim_u = sum(int(c.dim_u) for c in self.components)
        self.dim_x = sum(int(c.dim_x) for c in self.components)
        self._u = np.cumsum([0] + [c.dim_u for c in self.components])
        self._x = np.cumsum([0] + [c.dim_x for c in self.components])
        measures = [getattr(c, "measure", "?") for c in self.components]
        if all(m == "length" for m in measures):
            self.measure = {1: "length", 2: "area"}.get(self.dim_x, "volume")
        else:
            self.measure = "product of " + ", ".join(measures)

    def sample(self, u):
        u = as_uniforms(u, self.dim_u)
        return np.concatenate([c.sample(u[..., self._u[j]:self._u[j + 1]])
                               for j, c in enumerate(self.components)], -1)

    def pdf(self, x):
        x = as_points(x, self.dim_x)
        p = 1.0
        for j, c in enumerate(self.components):
            p = p * c.pdf(x[..., self._x[j]:self._x[j + 1]])
        return p

    def invert(self, x):
        x = as_points(x, self.dim_x)
        return np.concatenate([c.invert(x[..., self._x[j]:self._x[j + 1]])
                               for j, c in enumerate(self.components)], -1)
