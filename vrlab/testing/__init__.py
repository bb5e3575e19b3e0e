"""Test tools shipped with vrlab: chi-square goodness of fit on charts, and the common checks
every estimator (:func:`check_estimator`), BSDF (:func:`check_bsdf`) and emitter
(:func:`check_emitter`) must pass."""
from .charts import (AtlasChart, BoxChart, CapChart, Chart, DiskChart, EllipsoidChart, HalfLineChart,
                     HemisphereChart, IntervalChart, ParallelogramChart, SphereChart, TriangleChart,
                     box_surface_chart)
from .ellipsoid_view import EllipsoidViewChart
from .estimators import check_estimator
from .bsdf_checks import check_bsdf
from .emitter_checks import check_emitter
from .chisquare import (GofResult, assert_gof, cell_integrals, chi2_discrete, chi2_gof, histogram,
                        integrate, pooled_chi2, sidak_threshold)

__all__ = [
    "AtlasChart", "BoxChart", "EllipsoidViewChart", "CapChart", "Chart", "DiskChart", "EllipsoidChart", "HalfLineChart",
    "HemisphereChart", "IntervalChart", "ParallelogramChart", "SphereChart", "TriangleChart",
    "box_surface_chart",
    "GofResult", "assert_gof", "cell_integrals", "chi2_discrete", "chi2_gof", "histogram", "integrate",
    "pooled_chi2", "sidak_threshold", "check_estimator", "check_bsdf", "check_emitter",
]

# Mitsuba 3 as the renderer's oracle (vrlab.testing.mitsuba): loaded on first use, it imports Mitsuba only to render
from .._lazy import lazy_attributes  # noqa: E402
_MITSUBA = ["assert_agrees_with_mitsuba", "mitsuba_reference", "render_test", "mean_z_test", "RenderTestResult",
            "MeanTestResult", "Agreement", "rgb_to_xyz", "sample_budget"]
__all__ += _MITSUBA
__getattr__, __dir__ = lazy_attributes(__name__, dict.fromkeys(_MITSUBA, "mitsuba"), __all__)
