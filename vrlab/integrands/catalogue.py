"""Lab integrands with closed forms (integral, integral of f^2, golden variances).

Names (``get(name)``; ``names()`` lists them):

* ``sin``: sin x on [0, pi/2] = 1 (Russian lecture 4).  Uniform: Var = pi^2/8 - 1.
  With p2(x) = 8x/pi^2: E[(f/p2)^2] = (pi^2/8) int_0^{pi/2} sin^2 x / x dx and
  int_0^a sin^2 x / x dx = (ln 2a + gamma - Ci(2a)) / 2.
* ``step-x2``: x^2 1[x > 1/2] on [0, 1] = 7/24 (lecture 4).  int f^2 = 31/160;
  sampling uniformly on [1/2, 1] instead of [0, 1] lowers the variance by
  (|A| - |B|) int f^2 = 31/320.
* ``exp``: e^x on [0, 1] = e - 1 (lecture 000).  Var = (e^2 - 1)/2 - (e - 1)^2 = 0.242036;
  antithetic factor 1 + rho = 1 + (e - (e - 1)^2) / Var = 0.03233; control h = x:
  beta* = Cov(f, h)/Var(h) = 12 (1 - (e - 1)/2) = 1.6903, factor 1 - rho^2 = 0.01628.
* ``gauss-bump``: exp(-(x - 1/2)^2 / (2 s^2)) on [0, 1], s = 0.05 (erf closed forms).
* ``disk-indicator``: 1[|x - (1/2, 1/2)| < 0.4] on [0, 1]^2 = 0.16 pi (discontinuous).
* ``smooth-2d``: e^x sin(pi y) on [0, 1]^2 = 2 (e - 1) / pi.
* ``glossy-light``: a 2D toy of Veach's glossy plates: f = L(x) rho(x) with a sharp
  Gaussian "glossy lobe" plus a diffuse floor, rho = k_s g(x) + k_d, lit by a big dim
  light whose edge cuts the lobe and a small bright one (away from it).  Techniques "brdf"
  (density proportional to rho) and "light" (lights by power, uniform on each): BRDF
  sampling wins on the lobe, light sampling on the small light; MIS gets both.  f is not
  a linear combination of the techniques' densities (:class:`GlossyLight`).
* ``glossy-light-in-span``: the same with the lobe well inside the big light, where f is
  -k_d + (k_s + k_d) p_brdf + k_d P p_light up to the lobe's tails (8e-7 of its mass): the
  defensive mixture with the densities as controls is exact by construction, up to a
  residual variance ~1e-9 of the plain mixture's (what "f in the span" buys).
* ``point-mass``: 3x^2 on [0, 1] plus a point mass 1/2 at x = 0.3 (a "delta light"),
  int f dmu = 1 + 1/2 = 3/2 over mu = length + counting at 0.3 (its value there is 1/2).
  Techniques "continuous" (OffAtoms(2x): never produces the atom) and "mixture"
  (PointMasses(2x, [0.3], [1/4])); importance sampling with the mixture has
  Var = int 9x^4 / (2x (3/4)) dx + (1/2)^2 / (1/4) - (3/2)^2 = 3/2 + 1 - 9/4 = 1/4.
  Uniform sampling (and every recipe built on it) cannot produce the atom and is refused.
* ``cos-hemisphere``: cos(theta) over the hemisphere = pi; uniform Var = pi^2/3,
  cosine sampling has zero variance.
* ``cos8-hemisphere``: cos^8(theta) = 2 pi / 9; cosine sampling Var = pi^2/8 - (2pi/9)^2,
  Phong(8) sampling zero variance.
"""
from __future__ import annotations

import numpy as np

from .. import checks
from .. import distributions as D
from .base import Integrand

E = np.e
EULER_GAMMA = float(np.euler_gamma)


def _sin() -> Integrand:
    from scipy import special  # imported on use (startup time)

    ci_pi = special.sici(np.pi)[1]
    sin2_over_x = 0.5 * (np.log(np.pi) + EULER_GAMMA - ci_pi)
    return Integrand(lambda x: np.sin(x[..., 0]), [(0, np.pi / 2)], 1.0, "sin", f2=np.pi / 4,
                     theory={"var:uniform": np.pi**2 / 8 - 1,
                             "var:linear": np.pi**2 / 8 * sin2_over_x - 1},
                     techniques={"uniform": D.UniformInterval(0, np.pi / 2),
                                 "linear": D.LinearInterval(0, np.pi / 2, 0, 1)})


def _step_x2() -> Integrand:
    f2, exact = 31 / 160, 7 / 24
    return Integrand(lambda x: np.where(x[..., 0] > 0.5, x[..., 0] ** 2, 0.0), [(0, 1)], exact, "step-x2",
                     f2=f2, theory={"var:uniform": f2 - exact**2, "var:half": 0.5 * f2 - exact**2},
                     techniques={"uniform": D.UniformInterval(0, 1), "half": D.UniformInterval(0.5, 1)})


def _exp() -> Integrand:
    var = (E * E - 1) / 2 - (E - 1) ** 2
    cov_x = 1 - (E - 1) / 2                      # Cov(e^U, U)
    rho_anti = (E - (E - 1) ** 2) / var          # corr(e^U, e^(1-U))
    return Integrand(lambda x: np.exp(x[..., 0]), [(0, 1)], E - 1, "exp", f2=(E * E - 1) / 2,
                     theory={"var:uniform": var, "antithetic_factor": 1 + rho_anti,
                             "cv_x:beta": 12 * cov_x, "cv_x:factor": 1 - 12 * cov_x**2 / var},
                     techniques={"uniform": D.UniformInterval(0, 1), "linear": D.LinearInterval(0, 1, 1, E)})


def _gauss_bump(mu: float = 0.5, s: float = 0.05) -> Integrand:
    def mass(scale):  # int_0^1 exp(-(x - mu)^2 / (2 scale^2)) dx
        from scipy import special

        return scale * np.sqrt(2 * np.pi) * (special.ndtr((1 - mu) / scale) - special.ndtr(-mu / scale))
    return Integrand(lambda x: np.exp(-0.5 * ((x[..., 0] - mu) / s) ** 2), [(0, 1)], mass(s), "gauss-bump",
                     f2=mass(s / np.sqrt(2)),
                     techniques={"uniform": D.UniformInterval(0, 1),
                                 "normal": D.TruncatedNormal(mu, 1.5 * s, 0, 1)})


def _disk_indicator(r: float = 0.4) -> Integrand:
    def f(x):
        return (np.sum((x - 0.5) ** 2, -1) < r * r).astype(float)
    return Integrand(f, [(0, 1), (0, 1)], np.pi * r * r, "disk-indicator", f2=np.pi * r * r)


def _smooth_2d() -> Integrand:
    return Integrand(lambda x: np.exp(x[..., 0]) * np.sin(np.pi * x[..., 1]), [(0, 1), (0, 1)],
                     (E - 1) * 2 / np.pi, "smooth-2d", f2=(E * E - 1) / 2 * 0.5)


class GlossyLight:
    """The ``glossy-light`` toy: f(x) = L(x) rho(x) on [0, 1]^2, with closed forms.

    rho = k_s g + k_d, g the density of a Gaussian lobe (``center``, ``sigma``, truncated
    to the square); L is ``L_k`` on light k (axis-aligned rectangles ``((x0, x1), (y0, y1),
    L_k)``, disjoint) and 0 elsewhere.  Techniques: ``brdf`` (density (k_s g + k_d) / (k_s + k_d))
    and ``light`` (lights by power L_k |A_k|, uniform on each).

    Default: the lobe sits about one sigma inside the right edge of the big dim light, so the
    edge cuts the highlight (17 % of the lobe is unlit), and a small bright light lies away
    from it.  Then f = L (k_s g + k_d) is *not* a linear combination of 1, p_brdf and
    p_light: g counts outside the light in p_brdf but not in f, so no control made of the
    technique densities removes all variance.  With ``center=(0.3, 0.5)`` (the catalogue's
    ``glossy-light-in-span``) the lobe lies 4.8 sigma inside the big light (L = 1), so
    f = k_s g + k_d L = -k_d + (k_s + k_d) p_brdf + k_d P p_light up to the lobe's tails
    beyond 4.8 sigma (P = sum_k L_k |A_k|), and the defensive mixture with its densities as
    controls (Owen & Zhou 2000) is exact by construction (residual variance ~1e-9 relative).

    Closed forms (``integrals``): with m(a, b) the mass of the truncated normal on [a, b]
    and int phi_s^2 = int phi_{s/sqrt2} / (2 s sqrt(pi)),
    int f = sum_k L_k (k_s G_k + k_d |A_k|) and
    int f^2 = sum_k L_k^2 (k_s^2 G2_k + 2 k_s k_d G_k + k_d^2 |A_k|), G_k = int_{A_k} g,
    G2_k = int_{A_k} g^2 (products of normal CDF differences over each side): exact up to
    rounding (``scipy.special.ndtr``, ~1e-15 relative; tests/test_integrands.py checks them
    against Gauss-Legendre quadrature to 1e-7).
    Checked: ``center`` two numbers in (0, 1), ``sigma`` > 0, ``k_s``, ``k_d`` >= 0 with a
    positive sum, ``lights`` non-empty, each inside the square with x0 < x1, y0 < y1, L > 0,
    and no two overlapping.
    """

    # edges on multiples of 1/32 so that grid quadrature (mc_variance) is exact at them
    LIGHTS = (((5 / 32, 15 / 32), (11 / 32, 21 / 32), 1.0),   # big dim light (the lobe on its edge)
              ((24 / 32, 25 / 32), (22 / 32, 23 / 32), 200.0))  # small bright light

    def __init__(self, *, center=(0.44, 0.5), sigma: float = 0.03, k_s: float = 1.0, k_d: float = 0.5,
                 lights=LIGHTS):
        self.center = _pair(center, "center", 0.0, 1.0, open_=True)
        self.sigma = checks.real(sigma, "sigma", low=0.0, low_open=True)
        self.k_s = checks.real(k_s, "k_s", low=0.0)
        self.k_d = checks.real(k_d, "k_d", low=0.0)
        if self.k_s + self.k_d <= 0:
            raise ValueError("k_s, k_d: need k_s + k_d > 0")
        self.lights = _lights(lights)
        self.lobe = D.Product([D.TruncatedNormal(c, self.sigma, 0, 1) for c in self.center])
        self.brdf = D.Mixture([self.lobe, D.UniformBox([(0, 1), (0, 1)])],
                              [self.k_s / (self.k_s + self.k_d), self.k_d / (self.k_s + self.k_d)])
        areas = np.array([(x[1] - x[0]) * (y[1] - y[0]) for x, y, _ in self.lights])
        powers = areas * np.array([L for *_, L in self.lights])
        self.light = D.Mixture([D.UniformBox([x, y]) for x, y, _ in self.lights], powers)

    def rho(self, x):
        return self.k_s * self.lobe.pdf(x) + self.k_d

    def radiance(self, x):
        out = np.zeros(x.shape[:-1])
        for (x0, x1), (y0, y1), L in self.lights:
            inside = (x[..., 0] >= x0) & (x[..., 0] <= x1) & (x[..., 1] >= y0) & (x[..., 1] <= y1)
            out = out + L * inside
        return out

    def __call__(self, x):
        return self.radiance(x) * self.rho(x)

    def _gauss_mass(self, lo, hi, c, scale):
        from scipy import special

        return special.ndtr((hi - c) / scale) - special.ndtr((lo - c) / scale)

    def integrals(self) -> tuple[float, float]:
        """(int f, int f^2) in closed form (Gaussian integrals over rectangles)."""
        s = self.sigma
        z = [self._gauss_mass(0, 1, c, s) for c in self.center]        # truncation masses
        total, total2 = 0.0, 0.0
        for (x0, x1), (y0, y1), L in self.lights:
            area = (x1 - x0) * (y1 - y0)
            g = np.prod([self._gauss_mass(a, b, c, s) / zi
                         for (a, b), c, zi in zip([(x0, x1), (y0, y1)], self.center, z)])
            # int g^2: phi_s(t)^2 = phi_{s/sqrt2}(t) / (2 s sqrt(pi))
            g2 = np.prod([self._gauss_mass(a, b, c, s / np.sqrt(2)) / (2 * s * np.sqrt(np.pi) * zi**2)
                          for (a, b), c, zi in zip([(x0, x1), (y0, y1)], self.center, z)])
            total += L * (self.k_s * g + self.k_d * area)
            total2 += L * L * (self.k_s**2 * g2 + 2 * self.k_s * self.k_d * g + self.k_d**2 * area)
        return float(total), float(total2)


def _glossy_light(name: str = "glossy-light", **settings) -> Integrand:
    toy = GlossyLight(**settings)
    exact, f2 = toy.integrals()
    return Integrand(toy, [(0, 1), (0, 1)], exact, name, f2=f2, theory={"smooth": False},  # light edges
                     techniques={"brdf": toy.brdf, "light": toy.light})


def _glossy_light_in_span() -> Integrand:
    return _glossy_light("glossy-light-in-span", center=(0.3, 0.5))


def _pair(value, name: str, low: float, high: float, open_: bool = False) -> tuple[float, float]:
    if isinstance(value, (str, bytes)) or not hasattr(value, "__len__") or len(value) != 2:
        raise TypeError(f"{name} must be a pair of numbers, got {checks.describe(value)}")
    return tuple(checks.real(v, f"{name}[{k}]", low=low, high=high, low_open=open_, high_open=open_)
                 for k, v in enumerate(value))


def _lights(lights) -> tuple:
    """``lights`` checked: rectangles ((x0, x1), (y0, y1), L) in the unit square, L > 0, disjoint."""
    if isinstance(lights, (str, bytes)) or not hasattr(lights, "__len__") or not len(lights):
        raise TypeError(f"lights must be a non-empty sequence of ((x0, x1), (y0, y1), L), got "
                        f"{checks.describe(lights)}")
    out = []
    for k, light in enumerate(lights):
        if isinstance(light, (str, bytes)) or not hasattr(light, "__len__") or len(light) != 3:
            raise TypeError(f"lights[{k}] must be ((x0, x1), (y0, y1), L), got {checks.describe(light)}")
        xs, ys = (_pair(light[j], f"lights[{k}][{j}]", 0.0, 1.0) for j in (0, 1))
        if xs[0] >= xs[1] or ys[0] >= ys[1]:
            raise ValueError(f"lights[{k}]: need x0 < x1 and y0 < y1, got {xs}, {ys}")
        out.append((xs, ys, checks.real(light[2], f"lights[{k}][2]", low=0.0, low_open=True)))
    for i, (ax, ay, _) in enumerate(out):
        for j, (bx, by, _) in enumerate(out[:i]):
            if min(ax[1], bx[1]) > max(ax[0], bx[0]) and min(ay[1], by[1]) > max(ay[0], by[0]):
                raise ValueError(f"lights: lights[{j}] and lights[{i}] overlap (the closed forms need disjoint lights)")
    return tuple(out)


def _point_mass(x0: float = 0.3, c: float = 0.5, m: float = 0.25) -> Integrand:
    ramp = D.LinearInterval(0, 1, 0, 1)                     # p = 2x
    var_mixture = 9 / (8 * (1 - m)) + c * c / m - (1 + c) ** 2
    return Integrand(lambda x: 3 * x[..., 0] ** 2, [(0, 1)], 1 + c, "point-mass", f2=9 / 5,
                     theory={"var:mixture": var_mixture, "smooth": False},
                     techniques={"continuous": D.OffAtoms(ramp, [x0]), "mixture": D.PointMasses(ramp, [x0], [m])},
                     atoms=[(x0, c)])


def _cos_hemisphere() -> Integrand:
    return Integrand(lambda w: np.clip(w[..., 2], 0, None), "hemisphere", np.pi, "cos-hemisphere",
                     f2=2 * np.pi / 3, theory={"var:uniform": np.pi**2 / 3, "var:cosine": 0.0},
                     techniques={"uniform": D.UniformHemisphere(), "cosine": D.CosineHemisphere()})


def _cosn_hemisphere(n: int = 8) -> Integrand:
    exact = 2 * np.pi / (n + 1)
    return Integrand(lambda w: np.clip(w[..., 2], 0, None) ** n, "hemisphere", exact, f"cos{n}-hemisphere",
                     f2=2 * np.pi / (2 * n + 1),
                     theory={"var:uniform": 2 * np.pi * 2 * np.pi / (2 * n + 1) - exact**2,
                             "var:cosine": np.pi**2 / n - exact**2, "var:phong": 0.0},
                     techniques={"uniform": D.UniformHemisphere(), "cosine": D.CosineHemisphere(),
                                 "phong": D.PhongLobe(n)})


CATALOGUE = {
    "sin": _sin,
    "step-x2": _step_x2,
    "exp": _exp,
    "gauss-bump": _gauss_bump,
    "disk-indicator": _disk_indicator,
    "smooth-2d": _smooth_2d,
    "glossy-light": _glossy_light,
    "glossy-light-in-span": _glossy_light_in_span,
    "cos-hemisphere": _cos_hemisphere,
    "cos8-hemisphere": _cosn_hemisphere,
    "point-mass": _point_mass,
}

#: Catalogue integrands with point masses (uniform sampling cannot produce their atoms).
WITH_ATOMS = frozenset({"point-mass"})


def names(*, atoms: bool = True) -> list[str]:
    """Names of the catalogue integrands; ``atoms=False`` leaves out those with point masses
    (on which uniform sampling, antithetic pairs of it, strata... cannot produce the atom)."""
    return [n for n in CATALOGUE if atoms or n not in WITH_ATOMS]


def get(name: str) -> Integrand:
    """A fresh catalogue integrand by name (``ValueError`` listing the names if unknown,
    ``TypeError`` for a non-string)."""
    if not isinstance(name, str):
        raise TypeError(f"name must be a catalogue integrand name (a string: {', '.join(CATALOGUE)}), "
                        f"got {type(name).__name__}")
    if name not in CATALOGUE:
        raise ValueError(f"name: unknown integrand {name!r}; choose one of {', '.join(CATALOGUE)}")
    return CATALOGUE[name]()
