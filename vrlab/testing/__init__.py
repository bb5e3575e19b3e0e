"""Test tools shipped with vrlab: chi-square goodness of fit on charts, and
:func:`check_estimator`, the common checks every estimator must pass."""
from .charts import (AtlasChart, BoxChart, CapChart, Chart, DiskChart, EllipsoidChart, HalfLineChart,
                     HemisphereChart, IntervalChart, ParallelogramChart, SphereChart, TriangleChart,
                     box_surface_chart)
from .ellipsoid_view import EllipsoidViewChart
from .estimators import check_estimator
from .chisquare import (GofResult, assert_gof, cell_integrals, chi2_discrete, chi2_gof, histogram,
                        integrate, pooled_chi2, sidak_threshold)

__all__ = [
    "AtlasChart", "BoxChart", "EllipsoidViewChart", "CapChart", "Chart", "DiskChart", "EllipsoidChart", "HalfLineChart",
    "HemisphereChart", "IntervalChart", "ParallelogramChart", "SphereChart", "TriangleChart",
    "box_surface_chart",
    "GofResult", "assert_gof", "cell_integrals", "chi2_discrete", "chi2_gof", "histogram", "integrate",
    "pooled_chi2", "sidak_threshold", "check_estimator",
]
