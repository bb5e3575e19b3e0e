"""Point masses ("delta lights") on a mixed measure: atoms next to a continuous density.

An integrand with a point mass of weight c_k at x = a_k, int f dmu = int g dx + sum_k c_k,
is an integral over the mixed measure mu = length + counting measure on the atoms
{a_k}.  Every density is taken with respect to mu (the renderer's convention for delta
lights, pbrt's "specular" samples made explicit):

* a continuous density p gives the atoms zero mass, so its density w.r.t. mu is p(x) off
  the atoms and **0 at an atom** (it cannot produce it);
* a sampler that returns a_k with probability m_k has density m_k at a_k;
* the integrand's value at a_k is its weight c_k.

Then f(X) / p(X) is unbiased for int f dmu whenever every atom with c_k != 0 has m_k > 0,
and MIS weights w_i = q_i / sum_k q_k (q_k = n_k p_k) give w = 1 at an atom to the only
techniques that can produce it: MIS, one-sample MIS, RIS, antithetic pairs and control
variates work unchanged.  For importance sampling with p,

    Var[f(X) / p(X)] = int_{off atoms} f^2 / p dx + sum_k c_k^2 / m_k - I^2.

* ``PointMasses(base, atoms, masses)``: with probability m_k return a_k, else a sample of
  the continuous ``base`` (1D).  One uniform: [0, M), M = sum m_k, picks the atom by the
  cumulative masses, [M, 1) is rescaled to [0, 1) for ``base`` (its other uniforms follow).
  pdf w.r.t. mu: m_k at x == a_k, (1 - M) base.pdf(x) elsewhere; invert: an atom -> the
  middle of its interval of u, else M + (1 - M) base.invert(x).  ``base=None`` (M = 1) is a
  pure delta light.
* ``OffAtoms(base, atoms)``: a continuous technique read on the mixed measure: the samples
  of ``base``, pdf 0 exactly at the atoms and base.pdf elsewhere.

An atom is matched by exact equality: ``sample`` returns the stored float64 value of a_k.
``atom_mass(dist, x)`` is the probability a distribution puts on the points x (0 for one
without atoms; mixtures add their components'); ``check_atom_densities`` is the check the
estimators run: a technique's pdf at an atom must equal the mass it puts there (a plain
continuous density there is its density w.r.t. length, not mu: wrap it in ``OffAtoms``).
"""
from __future__ import annotations

from typing import Any

import numpy as np

from .. import checks
from .base import Distribution, as_float, as_points, as_uniforms

_TOP = np.nextafter(1.0, 0.0)


def as_atoms(atoms: Any, name: str = "atoms") -> np.ndarray:
    """``atoms`` as a 1-D float64 array of distinct finite numbers (shape (k,) or (k, 1)), k >= 1."""
    a = np.array(as_float(atoms, name), dtype=np.float64)
    if a.ndim == 2 and a.shape[1] == 1:
        a = a[:, 0]
    if a.ndim == 0:
        a = a[None]
    if a.ndim != 1 or a.size == 0:
        raise ValueError(f"{name}: expected a non-empty 1-D list of points, got shape {a.shape}")
    if not np.all(np.isfinite(a)):
        k = int(np.argmax(~np.isfinite(a)))
        raise ValueError(f"{name}: must be finite, but entry {k} is {a[k]}")
    if len(np.unique(a)) != len(a):
        raise ValueError(f"{name}: the atoms must be distinct, got {a.tolist()}")
    return a


def _match(x: np.ndarray, atoms: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(hit, k) for points x (..., 1): whether x equals an atom, and which (0 where not)."""
    eq = x[..., 0][..., None] == atoms
    return eq.any(-1), np.argmax(eq, -1)


def atom_mass(dist: Any, x: Any) -> np.ndarray:
    """Probability that ``dist`` produces exactly the points ``x (..., 1)``: its
    ``atom_mass`` if it has one, sum_k c_k atom_mass(p_k) for a mixture, else 0 (continuous)."""
    x = as_points(x, 1)
    own = getattr(dist, "atom_mass", None)
    if callable(own):
        return np.asarray(own(x), dtype=float)
    comps, probs = getattr(dist, "components", None), getattr(dist, "probabilities", None)
    if comps is not None and probs is not None and len(comps) == len(probs):     # a Mixture
        return sum(float(c) * atom_mass(d, x) for d, c in zip(comps, probs))
    return np.zeros(x.shape[:-1])


def check_atom_densities(dist: Any, atoms: Any, name: str = "distribution", who: str = "") -> np.ndarray:
    """The mass ``dist`` puts on each atom (k,), after checking that its pdf there equals that
    mass (its density w.r.t. the mixed measure); ``ValueError`` naming ``name`` and the atom."""
    pts = as_atoms(atoms)[:, None]
    mass = np.asarray(atom_mass(dist, pts), dtype=float)
    dens = np.asarray(dist.pdf(pts), dtype=float)
    k = len(pts)
    mass = np.broadcast_to(mass, np.broadcast_shapes(mass.shape, dens.shape)).reshape(-1, k)
    dens = np.broadcast_to(dens, mass.shape[:-1] + (k,) if dens.ndim else (k,)).reshape(-1, k)
    bad = ~np.isclose(dens, mass, rtol=1e-9, atol=1e-300)
    if bad.any():
        b, j = (int(i) for i in np.argwhere(bad)[0])
        what = f"{type(dist).__name__}" + (f" in {who}" if who else "")
        hint = (" (a density w.r.t. length, but the atom has length zero: wrap the technique as "
                "OffAtoms(dist, atoms) so that its density w.r.t. the mixed measure is 0 there)"
                if mass[b, j] == 0 else "")
        raise ValueError(f"{name}: {what} has density {dens[b, j]:.6g} at the atom x = {pts[j, 0]:g} but "
                         f"produces it with probability {mass[b, j]:.6g}; on a mixed measure the pdf at an "
                         f"atom must be that probability{hint}")
    return mass.min(0)


def _base(base: Any, name: str = "base"):
    base = checks.distribution(base, name)
    if getattr(base, "dim_x", 1) != 1:
        raise ValueError(f"{name}: point masses are one-dimensional, but {type(base).__name__} has "
                         f"dim_x = {base.dim_x}")
    if isinstance(base, PointMasses) or callable(getattr(base, "atom_mass", None)):
        raise ValueError(f"{name}: {type(base).__name__} already has atoms; give all of them to one PointMasses")
    return base


class PointMasses(Distribution):
    """Atoms ``atoms`` with probabilities ``masses``, else a sample of the continuous ``base``.

    pdf w.r.t. mu = length + counting on the atoms: m_k at a_k, (1 - sum m) base.pdf elsewhere.
    Checked: ``base`` a 1-D distribution without atoms, or None (then the masses must sum to
    1: a pure delta light); ``atoms`` distinct finite numbers; ``masses`` one finite value in
    (0, 1] per atom with sum < 1 when there is a base (sum = 1 up to 1e-12 without).
    """

    dim_x = 1

    def __init__(self, base=None, atoms: Any = (), masses: Any = ()):
        self.base = None if base is None else _base(base)
        self.atoms = as_atoms(atoms)
        m = np.atleast_1d(np.array(as_float(masses, "masses"), dtype=np.float64))
        if m.shape != self.atoms.shape:
            raise ValueError(f"masses: expected {len(self.atoms)} values (one per atom), got {m.size}")
        if not np.all(np.isfinite(m) & (m > 0) & (m <= 1)):
            k = int(np.argmax(~(np.isfinite(m) & (m > 0) & (m <= 1))))
            raise ValueError(f"masses: each must be in (0, 1], but masses[{k}] is {m[k]!r}")
        total = float(m.sum())
        if self.base is None:
            if abs(total - 1.0) > 1e-12:
                raise ValueError(f"masses: without a base the masses must sum to 1, got {total!r}")
            m = m / total
        elif not total < 1.0:
            raise ValueError(f"masses: with a base they must sum to < 1 (the rest samples the base), got {total!r}")
        self.masses = m
        self.cdf = np.concatenate([[0.0], np.cumsum(m)])
        if self.base is None:
            self.cdf[-1] = 1.0
        self.atom_total = float(self.cdf[-1])
        self.dim_u = 1 if self.base is None else int(self.base.dim_u)
        base_measure = "length" if self.base is None else getattr(self.base, "measure", "length")
        self.measure = f"{base_measure} + counting on the atoms"

    def atom_mass(self, x):
        """m_k where x == a_k, 0 elsewhere (shape x.shape[:-1])."""
        hit, k = _match(as_points(x, 1), self.atoms)
        return np.where(hit, self.masses[k], 0.0)

    def sample(self, u):
        u = as_uniforms(u, self.dim_u)
        u0 = u[..., 0]
        k = np.clip(np.searchsorted(self.cdf, u0, side="right") - 1, 0, len(self.atoms) - 1)
        atom = self.atoms[k][..., None]
        if self.base is None:
            return atom
        rest = np.clip((u0 - self.atom_total) / (1.0 - self.atom_total), 0.0, _TOP)
        x = np.asarray(self.base.sample(np.concatenate([rest[..., None], u[..., 1:]], -1)), dtype=float)
        return np.where((u0 < self.atom_total)[..., None], atom, x)

    def pdf(self, x):
        x = as_points(x, 1)
        hit, k = _match(x, self.atoms)
        if self.base is None:
            return np.where(hit, self.masses[k], 0.0)
        cont = (1.0 - self.atom_total) * np.asarray(self.base.pdf(x), dtype=float)
        return np.where(hit, self.masses[k], cont)

    def invert(self, x):
        x = as_points(x, 1)
        hit, k = _match(x, self.atoms)
        mid = 0.5 * (self.cdf[k] + self.cdf[k + 1])
        if self.base is None:
            return mid[..., None]
        ub = np.asarray(self.base.invert(x), dtype=float)
        cont = self.atom_total + (1.0 - self.atom_total) * ub[..., 0]
        u0 = np.where(hit, mid, cont)
        return np.concatenate([u0[..., None], ub[..., 1:]], -1) if ub.shape[-1] > 1 else u0[..., None]

    def _repr_fields(self):
        return {"base": self.base, "atoms": self.atoms.tolist(), "masses": self.masses.round(6).tolist()}


class OffAtoms(Distribution):
    """A continuous technique ``base`` on the mixed measure: its samples, pdf 0 exactly at the
    ``atoms`` (it never produces them), base.pdf elsewhere.  Checked: ``base`` a 1-D
    distribution without atoms; ``atoms`` distinct finite numbers."""

    dim_x = 1

    def __init__(self, base, atoms: Any):
        self.base = _base(base)
        self.atoms = as_atoms(atoms)
        self.dim_u = int(self.base.dim_u)
        self.measure = f"{getattr(self.base, 'measure', 'length')} + counting on the atoms"   # as PointMasses'

    def atom_mass(self, x):
        """0 everywhere: a continuous technique never produces an atom."""
        return np.zeros(as_points(x, 1).shape[:-1])

    def sample(self, u):
        return self.base.sample(u)

    def pdf(self, x):
        x = as_points(x, 1)
        hit, _ = _match(x, self.atoms)
        return np.where(hit, 0.0, np.asarray(self.base.pdf(x), dtype=float))

    def invert(self, x):
        return self.base.invert(x)

    def _repr_fields(self):
        return {"base": self.base, "atoms": self.atoms.tolist()}
