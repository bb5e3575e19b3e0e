"""Point masses in the estimator layer: the check every estimator runs on an integrand with atoms.

An integrand with atoms (``Integrand(..., atoms=[(a_k, c_k)])``) is integrated over the mixed
measure mu = length + counting on the atoms, and every technique's density is taken w.r.t. mu
(:mod:`vrlab.distributions.point_masses`).  The estimators need nothing else: with
q_k = n_k p_k(x), an atom a produced by technique i alone gets the MIS weight
w_i = q_i / sum_k q_k = 1, and f(a) / p(a) = c / m is the atom's share, so importance
sampling, MIS (every heuristic), one-sample MIS, RIS, antithetic pairs and control variates
stay unbiased.  Two mistakes would bias them silently, and ``check_atoms`` refuses both
(``ValueError`` naming the technique and the atom):

* a technique whose pdf at an atom is not the probability that it produces the atom (a plain
  continuous density there is w.r.t. length: it claims a share of the atom in the MIS
  weights that its samples never collect; wrap it as ``OffAtoms(dist, atoms)``);
* an atom with c_k != 0 that no technique in use produces (only continuous techniques: the
  estimate would miss c_k).
"""
from __future__ import annotations

from typing import Sequence

import numpy as np


def check_atoms(integrand, techniques: Sequence, names: Sequence[str], who: str) -> None:
    """Refuse ``techniques`` (with argument ``names``) for ``integrand``'s atoms, see the module."""
    if not integrand.atoms:
        return
    from ..distributions.point_masses import atom_mass, check_atom_densities

    points, weights = integrand.atom_points, integrand.atom_weights
    reach = np.zeros(len(points))
    for dist in techniques:
        reach += np.asarray(atom_mass(dist, points), dtype=float).reshape(-1, len(points)).min(0) > 0
    missed = (weights != 0) & (reach == 0)
    if missed.any():
        k = int(np.argmax(missed))
        used = ", ".join(f"{n} = {type(d).__name__}" for d, n in zip(techniques, names))
        raise ValueError(f"{who}: integrand {integrand.name!r} has a point mass {weights[k]:g} at the atom "
                         f"x = {points[k, 0]:g} that no technique can produce ({used}: continuous, they give it "
                         "probability 0), so the estimate would miss it; add a technique with that atom "
                         "(vrlab.distributions.PointMasses)")
    for dist, name in zip(techniques, names):
        check_atom_densities(dist, points, name, who)
