"""Charts of the chi-square harness: parameterisations of sampling domains by the unit square.

They are defined in the warps layer, :mod:`vrlab.distributions.charts` (the quadrature of
:func:`vrlab.integrands.mc_variance` uses them too); this module keeps their names under
``vrlab.testing``.
"""
from ..distributions.charts import (DEGENERATE, AtlasChart, BoxChart, CapChart, Chart, DiskChart,
                                    EllipsoidChart, HalfLineChart, HemisphereChart, IntervalChart,
                                    ParallelogramChart, SphereChart, TriangleChart, box_surface_chart)

__all__ = ["DEGENERATE", "AtlasChart", "BoxChart", "CapChart", "Chart", "DiskChart", "EllipsoidChart",
           "HalfLineChart", "HemisphereChart", "IntervalChart", "ParallelogramChart", "SphereChart",
           "TriangleChart", "box_surface_chart"]
