"""``Integrand``: a vectorised f, its domain, and what is known about it in closed form.

``f`` receives points of shape ``(..., k)`` and returns ``(...)`` (or ``(*batch, ...)``
for a batched integral, e.g. one integral per pixel).  ``domain`` is a box
``[(a1, b1), ..., (ak, bk)]`` or one of the named domains ``"sphere"``,
``"hemisphere"`` (unit directions, solid angle) and ``"disk"`` (unit disk, area).
``exact`` is the integral; ``f2`` the integral of f^2 over the domain, which gives the
variance of plain uniform sampling, Var[f(X) / p] = |domain| * f2 - exact^2.

The contract is checked at every call (``Integrand.__call__``, which every estimator
uses): ``f`` must return real values of shape ``x.shape[:-1]`` (optionally with leading
batch axes), all finite.  A wrong shape (``(n, 1)`` for ``(n,)``, one scalar for n
points) or a NaN/inf raises ``ValueError`` naming the integrand and the first bad point.
Subclasses change ``f``, not ``__call__``.

Point masses (``atoms=[(a_k, c_k), ...]``, 1D boxes): the integral is over the mixed measure
mu = length + counting measure on the atoms, int f dmu = int f dx + sum_k c_k (``exact`` is
that total), and ``__call__`` returns the weight c_k at x == a_k exactly (``f`` is the
continuous part, :meth:`Integrand.continuous`); see :mod:`vrlab.distributions.point_masses`.
Estimators refuse a technique set that cannot produce an atom, ``uniform()`` is the uniform
density read on mu (0 at the atoms) and ``f2`` is the integral of f^2 dx off the atoms.  :func:`vrlab.integrands.lookup.as_integrand` is what
estimators accept: an ``Integrand`` or a catalogue name.
"""
from __future__ import annotations

from typing import Any, Callable

import numpy as np

from .. import checks
from ..distributions import Disk, UniformBox, UniformHemisphere, UniformSphere
from ..distributions.interval import as_bounds

NAMED_DOMAINS = {
    "sphere": (3, 4 * np.pi, UniformSphere),
    "hemisphere": (3, 2 * np.pi, UniformHemisphere),
    "disk": (2, np.pi, Disk),
}


class Integrand:
    """A vectorised integrand over a domain, with optional closed forms.

    Parameters: ``f`` (callable, (..., k) -> (...)), ``domain`` (box or named),
    ``exact`` (the integral, scalar or batch-shaped), ``name``, ``f2`` (integral of
    f^2), ``theory`` (extra closed forms, e.g. golden variances, by key),
    ``techniques`` (named distributions suited to this integrand: estimators accept
    these names wherever they take a distribution), ``controls`` (named control
    variates: name -> ``(h, integral of h)``, for ``ControlVariate("name")``) and
    ``targets`` (named unnormalised densities, for ``RIS(target="name")``) and ``atoms``
    (point masses ``[(a_k, c_k), ...]`` on a 1D box: distinct points of the domain, finite
    weights; ``atom_points`` (k, 1) and ``atom_weights`` (k,) hold them).
    """

    #: point masses ((a_k, c_k), ...); class defaults for subclasses that set their own fields
    atoms: tuple = ()
    atom_points: np.ndarray = np.empty((0, 1))
    atom_weights: np.ndarray = np.empty(0)

    def __init__(self, f: Callable[[np.ndarray], np.ndarray], domain: Any, exact: Any = None,
                 name: str | None = None, *, f2: float | None = None, theory: dict | None = None,
                 techniques: dict | None = None, controls: dict | None = None, targets: dict | None = None,
                 atoms: Any = None):
        if not callable(f):
            raise TypeError(f"f must be callable, got {type(f).__name__}")
        self.f = f
        if isinstance(domain, str):
            if domain not in NAMED_DOMAINS:
                raise ValueError(f"domain: unknown name {domain!r}; use a box [(a, b), ...] or one of "
                                 f"{sorted(NAMED_DOMAINS)}")
            self.dim, self.volume, _ = NAMED_DOMAINS[domain]
            self.bounds = None
        else:
            self.bounds = as_bounds(domain, "domain")
            self.dim = len(self.bounds)
            self.volume = float(np.prod(self.bounds[:, 1] - self.bounds[:, 0]))
        self.domain = domain
        if exact is None:
            self.exact = None
        elif np.ndim(exact) == 0 and not isinstance(exact, (list, tuple)):
            self.exact = checks.real(exact, "exact")
        else:
            self.exact = checks.finite_array(exact, "exact")
        if name is not None and not isinstance(name, str):
            raise TypeError(f"name must be a string, got {type(name).__name__}")
        self.name = name or getattr(f, "__name__", "f")
        self.f2 = None if f2 is None else checks.real(f2, "f2", low=0.0)
        for arg, value in (("theory", theory), ("techniques", techniques), ("controls", controls),
                           ("targets", targets)):
            if value is not None and not isinstance(value, dict):
                raise TypeError(f"{arg} must be a dict, got {type(value).__name__}")
        self.theory = dict(theory or {})
        self.techniques = dict(techniques or {})
        for key, dist in self.techniques.items():
            if not all(hasattr(dist, a) for a in ("dim_u", "sample", "pdf")):
                raise TypeError(f"techniques[{key!r}]: {dist!r} is not a distribution (needs dim_u, sample, pdf)")
        self.controls = dict(controls or {})
        for key, pair in self.controls.items():
            if not (isinstance(pair, tuple) and len(pair) == 2 and callable(pair[0])):
                raise TypeError(f"controls[{key!r}]: expected a pair (h, integral of h) with h callable")
        self.targets = dict(targets or {})
        for key, t in self.targets.items():
            if not callable(t):
                raise TypeError(f"targets[{key!r}]: expected a callable (points -> unnormalised density)")
        self.atoms, self.atom_points, self.atom_weights = _atoms(atoms, self.bounds)

    def on_domain(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray | None]:
        """``(x', inside)``: points ``x (..., dim)`` (checked: that shape, no NaN) with those
        outside the domain replaced by a point of it (the nearest on a box, the mirror image
        below the hemisphere's equator, the radial projection outside the disk), and the mask
        of the points inside; ``inside`` is None when every point is (one min and max per
        coordinate).  A box keeps points within 1e-12 (relative) of its faces: rounding."""
        x = np.asarray(x)
        if x.ndim == 0 or x.shape[-1] != self.dim:
            raise ValueError(f"points: integrand {self.name!r} has a {self.dim}-dimensional domain, got points of "
                             f"shape {x.shape} (a distribution's sample must return shape (..., {self.dim}))")
        if x.size == 0 or (self.bounds is None and self.domain not in ("hemisphere", "disk")):
            return x, None
        flat = x.reshape(-1, self.dim)
        if self.bounds is not None:
            lo, hi = self.bounds[:, 0], self.bounds[:, 1]
            slack = 1e-12 * np.maximum(1.0, np.maximum(np.abs(lo), np.abs(hi)))
            lo, hi = lo - slack, hi + slack
            if _within(flat, lo, hi):
                return x, None
            inside = np.all((x >= lo) & (x <= hi), -1)
            stand_in = np.clip(x, self.bounds[:, 0], self.bounds[:, 1])
        elif self.domain == "hemisphere":
            if flat[:, 2].min() >= 0:
                return x, None
            inside = x[..., 2] >= 0
            stand_in = x * np.array([1.0, 1.0, -1.0], x.dtype)
        else:                                                             # the unit disk
            r2 = np.sum(x * x, -1)
            if r2.max() <= 1 + 1e-12:
                return x, None
            inside = r2 <= 1 + 1e-12
            stand_in = x / np.sqrt(np.maximum(r2, 1.0))[..., None]
        if np.isnan(x).any():
            raise ValueError(f"points: NaN among the points at which integrand {self.name!r} is evaluated "
                             "(a distribution's sample returned NaN)")
        return np.where(inside[..., None], x, stand_in.astype(x.dtype, copy=False)), inside

    def _domain_values(self, x: np.ndarray) -> np.ndarray:
        """f on the domain, 0 off it (the integral is over the domain), checked."""
        x, inside = self.on_domain(x)
        out = checked_values(self.f(x), x, f"integrand {self.name!r}")
        return out if inside is None else np.where(inside, out, 0).astype(out.dtype, copy=False)

    def continuous(self, x: np.ndarray) -> np.ndarray:
        """f(x) without the point masses (checked as ``__call__``): the part integrated dx."""
        return self._domain_values(x)

    def __call__(self, x: np.ndarray) -> np.ndarray:
        """f(x), checked: real, finite, one value per point (leading batch axes allowed); 0 at
        points outside the domain (a technique whose support is wider than the domain, such as
        an exponential on a box or the sphere on the hemisphere, samples them)."""
        x = np.asarray(x)
        out = self._domain_values(x)
        if not self.atoms:
            return out
        eq = x[..., 0][..., None] == self.atom_points[:, 0]       # an atom: its weight (density w.r.t. mu)
        hit = eq.any(-1)
        return np.where(hit, self.atom_weights[np.argmax(eq, -1)], out).astype(out.dtype, copy=False) \
            if hit.any() else out

    def technique(self, name: str, arg: str = "distribution"):
        """The distribution named ``name`` in :attr:`techniques` (``ValueError`` naming ``arg``)."""
        return _named(self.techniques, name, arg, f"integrand {self.name!r} has no technique")

    def control(self, name: str, arg: str = "control") -> tuple:
        """``(h, integral of h)`` of the control variate named ``name`` in :attr:`controls`."""
        return _named(self.controls, name, arg, f"integrand {self.name!r} has no control")

    def target(self, name: str, arg: str = "target"):
        """The unnormalised density named ``name`` in :attr:`targets`."""
        return _named(self.targets, name, arg, f"integrand {self.name!r} has no target")

    def uniform(self):
        """The uniform distribution on the domain (the default importance sampler); with atoms,
        read on the mixed measure (``OffAtoms``: density 0 at the atoms, which it never produces)."""
        if self.bounds is None:
            return NAMED_DOMAINS[self.domain][2]()
        if self.atoms:
            from ..distributions.point_masses import OffAtoms
            return OffAtoms(UniformBox(self.bounds), self.atom_points)
        return UniformBox(self.bounds)

    @property
    def uniform_variance(self) -> float | None:
        """Var of one uniform-sampling term f(X)/p = |D| f(X): |D| * f2 - exact^2 (closed form);
        None with atoms (uniform sampling never produces them: it is biased)."""
        if self.atoms or self.f2 is None or self.exact is None or np.ndim(self.exact) != 0:
            return None
        return self.volume * self.f2 - self.exact**2

    def __repr__(self) -> str:
        return f"Integrand({self.name!r}, domain={self.domain!r}, exact={self.exact!r})"


def _atoms(atoms: Any, bounds) -> tuple[tuple, np.ndarray, np.ndarray]:
    """``atoms`` [(a_k, c_k), ...] checked: ``((a_k, c_k), ...)``, points (k, 1), weights (k,)."""
    if atoms is None or (isinstance(atoms, (list, tuple)) and not atoms):
        return (), np.empty((0, 1)), np.empty(0)
    if bounds is None or len(bounds) != 1:
        raise ValueError("atoms: point masses are supported on 1D box domains only")
    if isinstance(atoms, (str, bytes, dict)) or not hasattr(atoms, "__len__") or \
            not all(hasattr(a, "__len__") and len(a) == 2 for a in atoms):
        raise TypeError(f"atoms: expected a list of pairs (point, weight), got {checks.describe(atoms)}")
    one = (lambda p: np.ravel(p)[0] if isinstance(p, (list, tuple, np.ndarray)) and np.size(p) == 1 else p)
    pts = [checks.real(one(a[0]), f"atoms[{k}][0] (the point)") for k, a in enumerate(atoms)]
    weights = [checks.real(a[1], f"atoms[{k}][1] (the weight)") for k, a in enumerate(atoms)]
    lo, hi = bounds[0]
    for k, p in enumerate(pts):
        if not lo <= p <= hi:
            raise ValueError(f"atoms[{k}][0]: the point {p:g} lies outside the domain [{lo:g}, {hi:g}]")
    if len(set(pts)) != len(pts):
        raise ValueError(f"atoms: the points must be distinct, got {pts}")
    return (tuple(zip(pts, weights)), np.array(pts, dtype=float)[:, None], np.array(weights, dtype=float))


def _named(table: dict, name: Any, arg: str, missing: str):
    if not isinstance(name, str):
        raise TypeError(f"{arg}: expected a name (str), got {type(name).__name__}")
    if name not in table:
        have = ", ".join(repr(k) for k in table) or "none"
        raise ValueError(f"{arg}: {missing} named {name!r}; it has: {have}")
    return table[name]


def _within(flat: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> bool:
    """Every row of ``flat (n, k)`` in the box [lo, hi] (False with a NaN): one min and max of
    the whole array when the box is a cube, else per column (numpy's axis-0 reductions of an
    (n, 2) array run 150x slower than these contiguous ones)."""
    if np.all(lo == lo[0]) and np.all(hi == hi[0]):
        return bool(flat.min() >= lo[0] and flat.max() <= hi[0])
    return all(flat[:, k].min() >= lo[k] and flat[:, k].max() <= hi[k] for k in range(flat.shape[1]))


def checked_values(values: Any, x: np.ndarray, who: str) -> np.ndarray:
    """``values`` of a function at points ``x (..., k)`` as a float array, checked: real,
    finite, shape ``x.shape[:-1]`` (leading batch axes allowed).  ``ValueError`` names
    ``who`` and the first bad point; ``TypeError`` for values that are not real numbers."""
    try:
        out = np.asarray(values)
        if out.dtype.kind == "c":            # casting would drop the imaginary part silently
            raise TypeError(f"got complex values (dtype {out.dtype})")
        if out.dtype != np.float32:          # float32 (the renderer's) stays float32
            out = np.asarray(out, dtype=float)
    except (TypeError, ValueError) as exc:
        raise TypeError(f"{who}: must return real numbers ({exc})") from None
    checks.one_value_per_point(out, x, who)
    # fast path, one reduction: a finite sum means every value is finite (a NaN or inf makes
    # the sum non-finite; so can an overflow of finite values, which the exact test clears)
    if out.size == 0 or np.isfinite(np.add.reduce(out, axis=None)):
        return out
    bad = ~np.isfinite(out)
    if bad.any():
        value, point = checks.first_bad_point(out, x, bad)
        raise ValueError(f"{who}: returned {value} at x = {point} ({int(bad.sum())} non-finite value(s)); "
                         "values must be finite")
    return out
