"""Point-set engine classes by canonical name (:mod:`vrlab.points.names`), except the
Cranley-Patterson rotation, which builds its base set from this table
(:mod:`vrlab.points.rotation`); :data:`vrlab.points.tools.POINT_SETS` adds it."""
from __future__ import annotations

from .halton import Halton, Hammersley
from .iid import Independent
from .lhs import LatinHypercube
from .sobol import Sobol
from .stratified import Stratified

__all__ = ["ENGINES"]

#: canonical name -> engine class (the rotation excepted)
ENGINES: dict[str, type] = {
    "independent": Independent,
    "stratified": Stratified,
    "lhs": LatinHypercube,
    "halton": Halton,
    "hammersley": Hammersley,
    "sobol": Sobol,
}
