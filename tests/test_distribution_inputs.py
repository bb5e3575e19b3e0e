"""Bad input to vrlab.distributions: every public class and function names the argument
(TypeError for a wrong kind, ValueError for a bad value), and float32 still works."""
import numpy as np
import pytest

from vrlab import AliasTable, CDFTable
from vrlab import distributions as D
from vrlab.distributions.base import ArgumentTypeError

NAN, INF = np.nan, np.inf
SPHERE = D.SphereSurface([0, 0, 0], 1.0)
SQUARE = D.RectangleSurface([0, 0, 0], [1, 0, 0], [0, 1, 0])
LOBE = D.PhongLobe(2)

# (id, callable, exception, names the message must contain)
CASES = [
    # --- discrete tables (also run for CDFTable below) ---
    ("alias-str", lambda: AliasTable("abc"), TypeError, ["weights"]),
    ("alias-none", lambda: AliasTable(None), TypeError, ["weights"]),
    ("alias-complex", lambda: AliasTable([1j, 2.0]), TypeError, ["weights"]),
    ("alias-ragged", lambda: AliasTable([[1.0], [1.0, 2.0]]), ValueError, ["weights"]),
    ("alias-pmf-str", lambda: AliasTable([1, 2]).pmf("a"), TypeError, ["i"]),
    ("alias-pmf-complex", lambda: AliasTable([1, 2]).pmf(1j), TypeError, ["i"]),
    ("alias-pmf-nan", lambda: AliasTable([1, 2]).pmf(NAN), ValueError, ["i"]),
    ("alias-pmf-inf", lambda: AliasTable([1, 2]).pmf([0, INF]), ValueError, ["i"]),
    ("alias-pmf-ragged", lambda: AliasTable([1, 2]).pmf([[1], [0, 1]]), ValueError, ["i"]),
    ("alias-sample-above", lambda: AliasTable([1, 2]).sample([0.5, 1.5]), ValueError, ["u"]),
    ("alias-sample-one", lambda: AliasTable([1, 2]).sample(1.0), ValueError, ["u"]),
    ("alias-sample-negative", lambda: AliasTable([1, 2]).sample([-0.5]), ValueError, ["u"]),
    ("alias-sample-nan", lambda: AliasTable([1, 2]).sample([[NAN]]), ValueError, ["u"]),
    ("alias-sample-str", lambda: AliasTable([1, 2]).sample("a"), TypeError, ["u"]),
    ("alias-remap-flag", lambda: AliasTable([1, 2]).sample([0.5], return_remapped="yes"),
     TypeError, ["return_remapped"]),
    ("alias-remap-big", lambda: AliasTable(np.ones(200_000) + np.arange(200_000)).sample_remap([2.0]),
     ValueError, ["u"]),
    ("cdf-sample-above", lambda: CDFTable([1, 2]).sample(2.0), ValueError, ["u"]),
    ("cdf-sample-nan", lambda: CDFTable([1, 2]).sample_remap([NAN]), ValueError, ["u"]),
    ("cdf-remap-flag", lambda: CDFTable([1, 2]).sample([0.5], return_remapped=1), TypeError, ["return_remapped"]),
    # --- intervals and boxes ---
    ("interval-str", lambda: D.UniformInterval("a", 1), TypeError, ["a"]),
    ("interval-none", lambda: D.UniformInterval(0, None), TypeError, ["b"]),
    ("interval-nan", lambda: D.UniformInterval(NAN, 1), ValueError, ["a"]),
    ("interval-inf", lambda: D.UniformInterval(0, INF), ValueError, ["b"]),
    ("interval-empty", lambda: D.UniformInterval(1, 1), ValueError, ["a", "b"]),
    ("interval-reversed", lambda: D.UniformInterval(2, 1), ValueError, ["a", "b"]),
    ("interval-overflow", lambda: D.UniformInterval(-1e308, 1e308), ValueError, ["a", "b"]),
    ("box-str", lambda: D.UniformBox("abc"), TypeError, ["bounds"]),
    ("box-none", lambda: D.UniformBox(None), TypeError, ["bounds"]),
    ("box-ragged", lambda: D.UniformBox([(0, 1), (0,)]), ValueError, ["bounds"]),
    ("box-three-columns", lambda: D.UniformBox([(0, 1, 2)]), ValueError, ["bounds"]),
    ("box-empty", lambda: D.UniformBox([]), ValueError, ["bounds"]),
    ("box-nan", lambda: D.UniformBox([(0, 1), (NAN, 1)]), ValueError, ["bounds"]),
    ("box-reversed", lambda: D.UniformBox([(0, 1), (1, 0)]), ValueError, ["bounds"]),
    ("box-volume-overflow", lambda: D.UniformBox([(0, 1e300)] * 3), ValueError, ["bounds"]),
    ("box-pdf-shape", lambda: D.UniformBox([(0, 1), (0, 1)]).pdf([0.5, 0.5, 0.5]), ValueError, ["x"]),
    ("box-sample-str", lambda: D.UniformBox([(0, 1)]).sample([["a"]]), TypeError, ["u"]),
    ("linear-f0-str", lambda: D.LinearInterval(0, 1, "a", 1), TypeError, ["f0"]),
    ("linear-f0-negative", lambda: D.LinearInterval(0, 1, -1, 1), ValueError, ["f0"]),
    ("linear-f1-nan", lambda: D.LinearInterval(0, 1, 1, NAN), ValueError, ["f1"]),
    ("linear-f1-inf", lambda: D.LinearInterval(0, 1, 1, INF), ValueError, ["f1"]),
    ("linear-both-zero", lambda: D.LinearInterval(0, 1, 0, 0), ValueError, ["f0", "f1"]),
    ("linear-a-str", lambda: D.LinearInterval("x", 1), TypeError, ["a"]),
    ("linear-reversed", lambda: D.LinearInterval(1, 0), ValueError, ["a", "b"]),
    ("linear-invert-shape", lambda: D.LinearInterval().invert([[0.1, 0.2]]), ValueError, ["x"]),
    ("exp-str", lambda: D.Exponential("a"), TypeError, ["rate"]),
    ("exp-zero", lambda: D.Exponential(0), ValueError, ["rate"]),
    ("exp-nan", lambda: D.Exponential(NAN), ValueError, ["rate"]),
    ("exp-inf", lambda: D.Exponential(INF), ValueError, ["rate"]),
    ("exp-upper-negative", lambda: D.Exponential(1, -1), ValueError, ["upper"]),
    ("exp-upper-str", lambda: D.Exponential(1, "x"), TypeError, ["upper"]),
    ("exp-upper-bool", lambda: D.Exponential(1, True), TypeError, ["upper"]),
    ("exp-no-mass", lambda: D.Exponential(1e-200, 1e-200), ValueError, ["rate", "upper"]),
    ("normal-sigma-zero", lambda: D.TruncatedNormal(0, 0), ValueError, ["sigma"]),
    ("normal-mu-str", lambda: D.TruncatedNormal("a"), TypeError, ["mu"]),
    ("normal-mu-inf", lambda: D.TruncatedNormal(INF), ValueError, ["mu"]),
    ("normal-a-nan", lambda: D.TruncatedNormal(0, 1, NAN, 1), ValueError, ["a"]),
    ("normal-b-str", lambda: D.TruncatedNormal(0, 1, 0, "1"), TypeError, ["b"]),
    ("normal-reversed", lambda: D.TruncatedNormal(0, 1, 1, 0), ValueError, ["a", "b"]),
    ("normal-no-mass", lambda: D.TruncatedNormal(0, 1, 100, 101), ValueError, ["a", "b"]),
    ("product-empty", lambda: D.Product([]), ValueError, ["components"]),
    ("product-not-list", lambda: D.Product(3), TypeError, ["components"]),
    ("product-not-distributions", lambda: D.Product([1, 2]), TypeError, ["components[0]"]),
    ("product-one-distribution", lambda: D.Product(D.UniformInterval()), TypeError, ["components"]),
    # --- tabulated ---
    ("pc1-str", lambda: D.PiecewiseConstant1D("abc"), TypeError, ["values"]),
    ("pc1-none", lambda: D.PiecewiseConstant1D([1, None]), TypeError, ["values"]),
    ("pc1-2d", lambda: D.PiecewiseConstant1D([[1, 2]]), ValueError, ["values"]),
    ("pc1-empty", lambda: D.PiecewiseConstant1D([]), ValueError, ["values"]),
    ("pc1-negative", lambda: D.PiecewiseConstant1D([1, -2]), ValueError, ["values"]),
    ("pc1-nan", lambda: D.PiecewiseConstant1D([1, NAN]), ValueError, ["values"]),
    ("pc1-inf", lambda: D.PiecewiseConstant1D([1, INF]), ValueError, ["values"]),
    ("pc1-zero", lambda: D.PiecewiseConstant1D([0, 0]), ValueError, ["values"]),
    ("pc1-domain-reversed", lambda: D.PiecewiseConstant1D([1, 2], (1, 0)), ValueError, ["domain"]),
    ("pc1-domain-str", lambda: D.PiecewiseConstant1D([1, 2], "ab"), TypeError, ["domain"]),
    ("pc1-domain-2d", lambda: D.PiecewiseConstant1D([1, 2], ((0, 1), (0, 1))), ValueError, ["domain"]),
    ("pc1-density-overflow", lambda: D.PiecewiseConstant1D([1.0, 1.0], (0, 1e-310)), ValueError, ["domain"]),
    ("pc2-1d", lambda: D.PiecewiseConstant2D([1, 2]), ValueError, ["image"]),
    ("pc2-str", lambda: D.PiecewiseConstant2D([["a"]]), TypeError, ["image"]),
    ("pc2-two-channels", lambda: D.PiecewiseConstant2D(np.ones((2, 2, 2))), ValueError, ["image"]),
    ("pc2-rgb-negative", lambda: D.PiecewiseConstant2D(-np.ones((2, 2, 3))), ValueError, ["image"]),
    ("pc2-nan", lambda: D.PiecewiseConstant2D([[1, NAN]]), ValueError, ["image"]),
    ("pc2-domain-1d", lambda: D.PiecewiseConstant2D(np.ones((2, 2)), (0, 1)), ValueError, ["domain"]),
    ("pc2-domain-nan", lambda: D.PiecewiseConstant2D(np.ones((2, 2)), ((0, 1), (0, NAN))), ValueError, ["domain"]),
    # --- planar ---
    ("disk-str", lambda: D.Disk("a"), TypeError, ["radius"]),
    ("disk-negative", lambda: D.Disk(-1), ValueError, ["radius"]),
    ("disk-zero", lambda: D.Disk(0), ValueError, ["radius"]),
    ("disk-inf", lambda: D.Disk(INF), ValueError, ["radius"]),
    ("disk-area-overflow", lambda: D.Disk(1e200), ValueError, ["radius"]),
    ("disk-center-nan", lambda: D.Disk(1, (0, NAN)), ValueError, ["center"]),
    ("disk-center-3d", lambda: D.Disk(1, (0, 0, 0)), ValueError, ["center"]),
    ("disk-center-str", lambda: D.Disk(1, "xy"), TypeError, ["center"]),
    ("disk-method", lambda: D.Disk(1, method="square"), ValueError, ["method", "concentric", "polar"]),
    ("disk-method-int", lambda: D.Disk(1, method=3), TypeError, ["method"]),
    ("disk-invert-shape", lambda: D.Disk().invert([1.0, 2.0, 3.0]), ValueError, ["x"]),
    ("triangle-str", lambda: D.Triangle("a", (0, 1), (1, 0)), TypeError, ["a"]),
    ("triangle-none", lambda: D.Triangle((0, 0), None, (1, 0)), TypeError, ["b"]),
    ("triangle-mixed-sizes", lambda: D.Triangle((0, 0), (0, 1, 0), (1, 0)), ValueError, ["a", "b", "c"]),
    ("triangle-nan", lambda: D.Triangle((0, 0), (0, 1), (NAN, 0)), ValueError, ["c"]),
    ("triangle-4d", lambda: D.Triangle((0, 0, 0, 0), (0, 1, 0, 0), (1, 0, 0, 0)), ValueError, ["a"]),
    ("triangle-repeated-vertex", lambda: D.Triangle((0, 0), (0, 0), (1, 0)), ValueError, ["a", "b", "c"]),
    ("triangle-collinear-3d", lambda: D.Triangle((0, 0, 0), (1, 1, 1), (2, 2, 2)), ValueError, ["a", "b", "c"]),
    ("triangle-pdf-shape", lambda: D.Triangle((0, 0), (0, 1), (1, 0)).pdf([[0.1, 0.1, 0.1]]), ValueError, ["x"]),
    ("rectangle-str", lambda: D.Rectangle("ab", (0, 1)), TypeError, ["xlim"]),
    ("rectangle-reversed", lambda: D.Rectangle((1, 0), (0, 1)), ValueError, ["xlim"]),
    ("rectangle-degenerate", lambda: D.Rectangle((0, 1), (1, 1)), ValueError, ["ylim"]),
    ("rectangle-nan", lambda: D.Rectangle((0, 1), (0, NAN)), ValueError, ["ylim"]),
    ("rectangle-three", lambda: D.Rectangle((0, 1, 2), (0, 1)), ValueError, ["xlim"]),
    ("concentric-shape", lambda: D.concentric_disk([0.5]), ValueError, ["u"]),
    # --- directions ---
    ("sphere-sample-str", lambda: D.UniformSphere().sample("ab"), TypeError, ["u"]),
    ("sphere-sample-shape", lambda: D.UniformSphere().sample(np.zeros((4, 3))), ValueError, ["u"]),
    ("sphere-pdf-shape", lambda: D.UniformSphere().pdf([1, 2]), ValueError, ["w"]),
    ("hemisphere-invert-shape", lambda: D.UniformHemisphere().invert(np.zeros((3, 2))), ValueError, ["w"]),
    ("hemisphere-pdf-none", lambda: D.UniformHemisphere().pdf(None), TypeError, ["w"]),
    ("cosine-method", lambda: D.CosineHemisphere(method="malley"), ValueError,
     ["method", "inversion", "disk", "sphere-shift"]),
    ("cosine-method-none", lambda: D.CosineHemisphere(method=None), TypeError, ["method"]),
    ("cosine-pdf-shape", lambda: D.CosineHemisphere().pdf(np.zeros(2)), ValueError, ["w"]),
    ("phong-str", lambda: D.PhongLobe("abc"), TypeError, ["exponent"]),
    ("phong-none", lambda: D.PhongLobe(None), TypeError, ["exponent"]),
    ("phong-bool", lambda: D.PhongLobe(True), TypeError, ["exponent"]),
    ("phong-complex", lambda: D.PhongLobe(1j), TypeError, ["exponent"]),
    ("phong-nan", lambda: D.PhongLobe(NAN), ValueError, ["exponent"]),
    ("phong-inf", lambda: D.PhongLobe(INF), ValueError, ["exponent"]),
    ("phong-negative", lambda: D.PhongLobe(-1), ValueError, ["exponent"]),
    ("ggx-str", lambda: D.GGX("abc"), TypeError, ["alpha"]),
    ("ggx-zero", lambda: D.GGX(0), ValueError, ["alpha"]),
    ("ggx-negative", lambda: D.GGX(-0.5), ValueError, ["alpha"]),
    ("ggx-nan", lambda: D.GGX(NAN), ValueError, ["alpha"]),
    ("ggx-inf", lambda: D.GGX(INF), ValueError, ["alpha"]),
    ("ggx-underflow", lambda: D.GGX(1e-200), ValueError, ["alpha"]),
    ("ggx-D-shape", lambda: D.GGX(0.3).D([0.0, 1.0]), ValueError, ["h"]),
    # --- anisotropic roughness (alpha_u along x, alpha_v along y) and visible normals ---
    ("ggx-alpha-v-str", lambda: D.GGX(0.3, "a"), TypeError, ["alpha_v"]),
    ("ggx-alpha-v-list", lambda: D.GGX(alpha_u=0.3, alpha_v=[0.2]), TypeError, ["alpha_v"]),
    ("ggx-alpha-v-zero", lambda: D.GGX(0.3, 0), ValueError, ["alpha_v"]),
    ("ggx-alpha-v-negative", lambda: D.GGX(0.3, -0.2), ValueError, ["alpha_v"]),
    ("ggx-alpha-v-nan", lambda: D.GGX(0.3, NAN), ValueError, ["alpha_v"]),
    ("ggx-alpha-v-inf", lambda: D.GGX(0.3, INF), ValueError, ["alpha_v"]),
    ("ggx-alpha-u-positional-zero", lambda: D.GGX(0, 0.3), ValueError, ["alpha", "alpha_u"]),
    ("ggx-alpha-u-nan", lambda: D.GGX(alpha_u=NAN, alpha_v=0.3), ValueError, ["alpha_u"]),
    ("ggx-alpha-u-str", lambda: D.GGX(alpha_u="rough", alpha_v=0.3), TypeError, ["alpha_u"]),
    ("ggx-alpha-u-bool", lambda: D.GGX(alpha_u=True, alpha_v=0.3), TypeError, ["alpha_u"]),
    ("ggx-alpha-u-without-v", lambda: D.GGX(alpha_u=0.3), TypeError, ["alpha_u", "alpha_v"]),
    ("ggx-alpha-and-alpha-u", lambda: D.GGX(0.3, alpha_u=0.2, alpha_v=0.2), TypeError, ["alpha", "alpha_u"]),
    ("ggx-no-alpha", lambda: D.GGX(), TypeError, ["alpha"]),
    ("ggx-anisotropic-alpha", lambda: D.GGX(0.1, 0.2).alpha, AttributeError, ["alpha", "alpha_u", "alpha_v"]),
    ("beckmann-alpha-u-negative", lambda: D.Beckmann(alpha_u=-1, alpha_v=0.2), ValueError, ["alpha_u"]),
    ("beckmann-alpha-v-str", lambda: D.Beckmann(0.2, "0.3"), TypeError, ["alpha_v"]),
    ("beckmann-alpha-v-nan", lambda: D.Beckmann(0.2, NAN), ValueError, ["alpha_v"]),
    ("beckmann-alpha-v-overflow", lambda: D.Beckmann(0.2, 1e60), ValueError, ["alpha_v"]),
    ("beckmann-G1-shape", lambda: D.Beckmann(0.2, 0.4).G1([0, 1], [0, 0, 1]), ValueError, ["v"]),
    ("vndf-normals", lambda: D.VisibleNormals(D.PhongLobe(2), [0, 0, 1]), TypeError, ["normals"]),
    ("vndf-wo-below", lambda: D.GGX(0.3).visible([0, 0.6, -0.8]), ValueError, ["wo"]),
    ("vndf-wo-horizon", lambda: D.Beckmann(0.3).visible([1, 0, 0]), ValueError, ["wo"]),
    ("vndf-wo-batch-below", lambda: D.GGX(0.3).visible([[0, 0, 1], [0, 0, -1]]), ValueError, ["wo"]),
    ("vndf-wo-zero", lambda: D.GGX(0.3).visible([0, 0, 0]), ValueError, ["wo"]),
    ("vndf-wo-nan", lambda: D.GGX(0.3).visible([NAN, 0, 1]), ValueError, ["wo"]),
    ("vndf-wo-str", lambda: D.GGX(0.3).visible("up"), TypeError, ["wo"]),
    ("vndf-wo-2d", lambda: D.GGX(0.3).visible([0, 1]), ValueError, ["wo"]),
    ("vndf-newton-zero", lambda: D.Beckmann(0.3).visible([0, 0, 1], newton_steps=0), ValueError, ["newton_steps"]),
    ("vndf-newton-float", lambda: D.Beckmann(0.3).visible([0, 0, 1], newton_steps=2.5), TypeError,
     ["newton_steps"]),
    ("vndf-u-shape", lambda: D.GGX(0.3).visible([0, 0, 1]).sample(np.zeros((4, 3))), ValueError, ["u"]),
    ("vndf-u-broadcast", lambda: D.GGX(0.3).visible(np.tile([0.0, 0.0, 1.0], (4, 1))).sample(np.zeros((5, 2))),
     ValueError, ["u", "wo"]),
    ("vndf-m-broadcast", lambda: D.Beckmann(0.3).visible(np.tile([0.0, 0.0, 1.0], (4, 1))).pdf(np.zeros((5, 3))),
     ValueError, ["m", "wo"]),
    ("vndf-invert-shape", lambda: D.GGX(0.3).visible([0, 0, 1]).invert([0, 1]), ValueError, ["m"]),
    ("cone-one", lambda: D.UniformCone(1.0), ValueError, ["cos_max"]),
    ("cone-below", lambda: D.UniformCone(-1.5), ValueError, ["cos_max"]),
    ("cone-nan", lambda: D.UniformCone(NAN), ValueError, ["cos_max"]),
    ("cone-str", lambda: D.UniformCone("a"), TypeError, ["cos_max"]),
    ("around-zero", lambda: LOBE.around([0, 0, 0]), ValueError, ["axis"]),
    ("around-nan", lambda: LOBE.around([NAN, 0, 1]), ValueError, ["axis"]),
    ("around-inf", lambda: LOBE.around([INF, 0, 1]), ValueError, ["axis"]),
    ("around-batch-zero", lambda: LOBE.around([[0, 0, 1], [0, 0, 0]]), ValueError, ["axis"]),
    ("around-str", lambda: LOBE.around("xyz"), TypeError, ["axis"]),
    ("around-none", lambda: LOBE.around(None), TypeError, ["axis"]),
    ("around-2d", lambda: LOBE.around([0, 1]), ValueError, ["axis"]),
    ("around-pdf-shape", lambda: LOBE.around([0, 0, 1]).pdf([0, 1]), ValueError, ["w"]),
    ("around-u-broadcast", lambda: LOBE.around(np.tile([0.0, 0.0, 1.0], (4, 1))).sample(np.zeros((5, 2))),
     ValueError, ["u", "axis"]),
    ("around-w-broadcast", lambda: LOBE.around(np.tile([0.0, 0.0, 1.0], (4, 1))).pdf(np.zeros((5, 3))),
     ValueError, ["w", "axis"]),
    ("oriented-not-distribution", lambda: D.Oriented(3, [0, 0, 1]), TypeError, ["local"]),
    ("oriented-1d", lambda: D.Oriented(D.UniformInterval(), [0, 0, 1]), ValueError, ["local"]),
    # --- frames ---
    ("frame-zero", lambda: D.Frame([0, 0, 0]), ValueError, ["n"]),
    ("frame-nan", lambda: D.Frame([NAN, 0, 1]), ValueError, ["n"]),
    ("frame-not-unit", lambda: D.Frame([[0, 0, 1], [0, 0, 2]]), ValueError, ["n"]),
    ("frame-str", lambda: D.Frame("abc"), TypeError, ["n"]),
    ("frame-2d", lambda: D.Frame([0, 1]), ValueError, ["n"]),
    ("frame-t-only", lambda: D.Frame([0, 0, 1], t=[1, 0, 0]), ValueError, ["t", "b"]),
    ("frame-t-not-orthogonal", lambda: D.Frame([0, 0, 1], [0, 0, 1], [0, 1, 0]), ValueError, ["t"]),
    ("frame-to-world-shape", lambda: D.Frame([0, 0, 1]).to_world([1, 0]), ValueError, ["v"]),
    ("frame-to-local-str", lambda: D.Frame([0, 0, 1]).to_local("abc"), TypeError, ["w"]),
    ("frame-broadcast", lambda: D.Frame(np.tile([0.0, 0.0, 1.0], (4, 1))).to_world(np.zeros((5, 3))),
     ValueError, ["v", "n"]),
    ("frame-take", lambda: D.Frame(np.tile([0.0, 0.0, 1.0], (4, 1))).take(7), IndexError, ["idx"]),
    ("frame-tile", lambda: D.Frame([[0, 0, 1]]).tile(0), ValueError, ["k"]),
    ("frame-tile-float", lambda: D.Frame([[0, 0, 1]]).tile(2.5), TypeError, ["k"]),
    ("to-world-v", lambda: D.to_world([1, 0], [0, 0, 1]), ValueError, ["v"]),
    ("to-local-n", lambda: D.to_local([1, 0, 0], [0, 0, 0]), ValueError, ["n"]),
    ("onb-shape", lambda: D.orthonormal_basis([0, 1]), ValueError, ["n"]),
    # --- surfaces ---
    ("rect-surface-str", lambda: D.RectangleSurface("abc", [1, 0, 0], [0, 1, 0]), TypeError, ["corner"]),
    ("rect-surface-nan", lambda: D.RectangleSurface([0, 0, 0], [NAN, 0, 0], [0, 1, 0]), ValueError, ["edge1"]),
    ("rect-surface-zero", lambda: D.RectangleSurface([0, 0, 0], [1, 0, 0], [0, 0, 0]), ValueError, ["edge2"]),
    ("rect-surface-parallel", lambda: D.RectangleSurface([0, 0, 0], [1, 0, 0], [2, 0, 0]), ValueError,
     ["edge1", "edge2"]),
    ("rect-surface-huge", lambda: D.RectangleSurface([0, 0, 0], [1e200, 0, 0], [0, 1e200, 0]), ValueError,
     ["edge1"]),
    ("rect-surface-matrix-str", lambda: D.RectangleSurface.from_matrix("x"), TypeError, ["matrix"]),
    ("rect-surface-matrix-nan", lambda: D.RectangleSurface.from_matrix(np.full((4, 4), NAN)), ValueError,
     ["matrix"]),
    ("rect-surface-flip", lambda: D.RectangleSurface.from_matrix(np.eye(4), "yes"), TypeError, ["flip_normals"]),
    ("rect-surface-intersect-shape", lambda: SQUARE.intersect([0, 5], [0, 0, -1]), ValueError, ["origin"]),
    ("rect-surface-t-min", lambda: SQUARE.intersect([0, 0, 5], [0, 0, -1], t_min="a"), TypeError, ["t_min"]),
    ("box-surface-negative", lambda: D.BoxSurface([0, 0, 0], -1), ValueError, ["half_extents"]),
    ("box-surface-two", lambda: D.BoxSurface([0, 0, 0], [1, 2]), ValueError, ["half_extents"]),
    ("box-surface-str", lambda: D.BoxSurface([0, 0, 0], "abc"), TypeError, ["half_extents"]),
    ("box-surface-nan", lambda: D.BoxSurface([0, 0, 0], [1, NAN, 1]), ValueError, ["half_extents"]),
    ("box-surface-huge", lambda: D.BoxSurface([0, 0, 0], 1e200), ValueError, ["half_extents"]),
    ("box-surface-center", lambda: D.BoxSurface([0, INF, 0], 1), ValueError, ["center"]),
    ("box-surface-rotation-str", lambda: D.BoxSurface([0, 0, 0], 1, rotation="r"), TypeError, ["rotation"]),
    ("box-surface-rotation-shape", lambda: D.BoxSurface([0, 0, 0], 1, rotation=np.eye(2)), ValueError,
     ["rotation"]),
    ("box-surface-matrix-flat", lambda: D.BoxSurface.from_matrix(np.diag([1.0, 1.0, 0.0, 1.0])), ValueError,
     ["matrix"]),
    ("box-surface-matrix-huge", lambda: D.BoxSurface.from_matrix(np.diag([1e200, 1.0, 1.0, 1.0])), ValueError,
     ["matrix"]),
    ("box-surface-face-shape", lambda: D.BoxSurface([0, 0, 0], 1).face([1, 0]), ValueError, ["x"]),
    ("sphere-surface-radius-str", lambda: D.SphereSurface([0, 0, 0], "r"), TypeError, ["radius"]),
    ("sphere-surface-radius-zero", lambda: D.SphereSurface([0, 0, 0], 0), ValueError, ["radius"]),
    ("sphere-surface-radius-nan", lambda: D.SphereSurface([0, 0, 0], NAN), ValueError, ["radius"]),
    ("sphere-surface-radius-tiny", lambda: D.SphereSurface([0, 0, 0], 1e-200), ValueError, ["radius"]),
    ("sphere-surface-center-str", lambda: D.SphereSurface("abc", 1), TypeError, ["center"]),
    ("sphere-surface-normal-shape", lambda: SPHERE.normal([[1, 0]]), ValueError, ["x"]),
    ("sphere-surface-t-min-nan", lambda: SPHERE.intersect([0, 0, 5], [0, 0, -1], t_min=NAN), ValueError,
     ["t_min"]),
    ("ellipsoid-matrix-str", lambda: D.EllipsoidSurface([0, 0, 0], "m"), TypeError, ["matrix"]),
    ("ellipsoid-matrix-flat", lambda: D.EllipsoidSurface([0, 0, 0], np.diag([1.0, 1.0, 0.0])), ValueError,
     ["matrix"]),
    ("ellipsoid-matrix-huge", lambda: D.EllipsoidSurface([0, 0, 0], 1e200 * np.eye(3)), ValueError, ["matrix"]),
    ("ellipsoid-radii-two", lambda: D.EllipsoidSurface.from_radii([0, 0, 0], [1, 2]), ValueError, ["radii"]),
    ("ellipsoid-radii-str", lambda: D.EllipsoidSurface.from_radii([0, 0, 0], "r"), TypeError, ["radii"]),
    ("ellipsoid-affine", lambda: D.EllipsoidSurface.from_matrix(np.ones((4, 4))), ValueError, ["matrix"]),
    # --- directions towards lights ---
    ("solid-angle-ref-nan", lambda: D.SolidAngleFromArea(SPHERE, [0, 0, NAN]), ValueError, ["ref"]),
    ("solid-angle-ref-str", lambda: D.SolidAngleFromArea(SPHERE, "abc"), TypeError, ["ref"]),
    ("solid-angle-surface", lambda: D.SolidAngleFromArea(3, [0, 0, 5]), TypeError, ["surface"]),
    ("solid-angle-pdf-at", lambda: D.SolidAngleFromArea(SQUARE, [0, 0, 5]).pdf_at([1, 2], [0, 0, 1]),
     ValueError, ["y"]),
    ("solid-angle-pdf-shape", lambda: SPHERE.solid_angle_from([0, 0, 5]).pdf([0, 1]), ValueError, ["w"]),
    ("sphere-cone-radius-str", lambda: D.SphereCone([0, 0, 0], "r", [0, 0, 5]), TypeError, ["radius"]),
    ("sphere-cone-radius-negative", lambda: D.SphereCone([0, 0, 0], [1.0, -1.0], [0, 0, 5]), ValueError,
     ["radius"]),
    ("sphere-cone-center-nan", lambda: D.SphereCone([0, NAN, 0], 1.0, [0, 0, 5]), ValueError, ["center"]),
    ("sphere-cone-broadcast", lambda: D.SphereCone(np.zeros((4, 3)), 1.0, np.ones((5, 3)) * 5), ValueError,
     ["center", "ref"]),
    ("sphere-cone-radius-broadcast", lambda: D.SphereCone(np.zeros(3), np.ones(4), np.ones((5, 3)) * 5),
     ValueError, ["radius"]),
    ("sphere-cone-u-broadcast", lambda: D.SphereCone(np.zeros(3), 1.0, np.ones((4, 3)) * 5).sample(np.zeros((5, 2))),
     ValueError, ["u", "ref"]),
    ("solid-angle-u-broadcast", lambda: SPHERE.solid_angle_from(np.ones((4, 3)) * 5).sample(np.zeros((5, 2))),
     ValueError, ["u", "ref"]),
    ("cone-from-ref", lambda: SPHERE.cone_from([INF, 0, 0]), ValueError, ["ref"]),
    # --- mixtures ---
    ("mixture-empty", lambda: D.Mixture([]), ValueError, ["components"]),
    ("mixture-not-distributions", lambda: D.Mixture([1, 2]), TypeError, ["components[0]"]),
    ("mixture-one-distribution", lambda: D.Mixture(D.UniformSphere()), TypeError, ["components"]),
    ("mixture-not-list", lambda: D.Mixture(None), TypeError, ["components"]),
    ("mixture-negative", lambda: D.Mixture([D.UniformSphere()], [-1]), ValueError, ["probabilities"]),
    ("mixture-all-zero", lambda: D.Mixture([D.UniformSphere()] * 2, [0, 0]), ValueError, ["probabilities"]),
    ("mixture-nan", lambda: D.Mixture([D.UniformSphere()] * 2, [1, NAN]), ValueError, ["probabilities"]),
    ("mixture-too-few", lambda: D.Mixture([D.UniformSphere()] * 2, [1]), ValueError, ["probabilities"]),
    ("mixture-too-many", lambda: D.Mixture([D.UniformSphere()], [1, 2]), ValueError, ["probabilities"]),
    ("mixture-str", lambda: D.Mixture([D.UniformSphere()], ["a"]), TypeError, ["probabilities"]),
    ("mixture-dimensions", lambda: D.Mixture([D.UniformInterval(), D.UniformSphere()]), ValueError,
     ["components"]),
    ("mixture-measures", lambda: D.Mixture([D.UniformBox([(0, 1)] * 3), D.UniformSphere()]), ValueError,
     ["components"]),
]


@pytest.mark.parametrize("make, exc, names", [c[1:] for c in CASES], ids=[c[0] for c in CASES])
def test_bad_input_names_the_argument(raises_naming, make, exc, names):
    with raises_naming(exc, *names) as info:
        make()
    assert "could not convert" not in str(info.value)


@pytest.mark.parametrize("cls", [AliasTable, CDFTable], ids=lambda c: c.__name__)
@pytest.mark.parametrize("weights", ["abc", None, [1j, 2.0], ["a", "b"], {"a": 1}],
                         ids=["str", "none", "complex", "strings", "dict"])
def test_discrete_non_numbers_are_type_and_value_errors(raises_naming, cls, weights):
    """Non-numbers are ``TypeError``s that stay ``ValueError``s (the tables' old contract)."""
    with raises_naming(ArgumentTypeError, "weights") as info:
        cls(weights)
    assert isinstance(info.value, TypeError) and isinstance(info.value, ValueError)
    assert "could not convert" not in str(info.value)


@pytest.mark.parametrize("cls", [AliasTable, CDFTable], ids=lambda c: c.__name__)
@pytest.mark.parametrize("u", [[0.2, 1.0], [-1e-3], [np.nan, 0.5], [[0.5], [np.inf]]],
                         ids=["one", "negative", "nan", "inf"])
def test_discrete_sample_rejects_u_outside_unit_interval(raises_naming, cls, u):
    t = cls([1.0, 2.0, 3.0])
    with raises_naming(ValueError, "u"):
        t.sample(u)
    with raises_naming(ValueError, "u"):
        t.sample_remap(u)


@pytest.mark.parametrize("cls", [AliasTable, CDFTable], ids=lambda c: c.__name__)
def test_discrete_valid_edge_input_still_works(cls):
    t = cls([1.0, 2.0, 3.0])
    assert t.sample(np.array([])).shape == (0,)
    assert t.sample(0.0) == 0 and t.sample(np.nextafter(1.0, 0.0)) == 2
    assert t.sample(np.float32([0.99]))[0] == 2
    assert t.pmf(np.int32(2)) == 0.5 and t.pmf(7) == 0.0
    assert t.sample([0.5], return_remapped=np.bool_(True))[0].shape == (1,)


def test_surface_without_methods_is_type_and_value_error(raises_naming):
    with raises_naming(ValueError, "surface") as info:
        D.SolidAngleFromArea(object(), [1.0, 2.0, 3.0])
    assert isinstance(info.value, TypeError)


def test_float32_scalars_and_zero_d_arrays_are_accepted():
    """Constructors take NumPy float32 scalars and 0-d arrays for float parameters."""
    f = np.float32
    assert D.GGX(f(0.25)).alpha == pytest.approx(0.25)
    assert D.GGX(np.array(0.25)).alpha == 0.25
    assert D.PhongLobe(np.array(3, np.int64)).exponent == 3.0
    assert D.UniformCone(f(0.5)).cos_max == 0.5
    assert D.Disk(f(2.0), np.array([0, 0], np.float32)).radius == 2.0
    assert D.Exponential(np.array(2.0, np.float32), f(1.0)).upper == 1.0
    assert D.UniformInterval(f(-1), np.array(1.0)).volume == 2.0
    assert D.LinearInterval(f(0), f(1), f(1), np.float16(2)).f1 == 2.0
    assert D.SphereSurface(np.zeros(3, np.float32), f(1.5)).radius == 1.5
    assert D.SphereCone(np.zeros(3, f), f(0.5), np.array([0, 0, 5], f)).radius == 0.5


def test_float32_arrays_stay_float32():
    """The renderer's float32 arrays keep their precision through the checked paths."""
    u = np.random.default_rng(1).random((50, 2)).astype(np.float32)
    n = np.array([[0.0, 0.6, 0.8]] * 50, np.float32)
    frame = D.Frame(n)
    assert frame.n.dtype == frame.t.dtype == np.float32
    w = frame.to_world(D.CosineHemisphere().sample(u))
    assert w.dtype == np.float32 and frame.to_local(w).dtype == np.float32
    assert D.to_world(D.GGX(0.3).sample(u), n).dtype == np.float32
    assert D.concentric_disk(u).dtype == np.float32
    cone = D.SphereCone(np.zeros(3, np.float32), np.full(50, 0.5, np.float32), n * 5)
    assert cone.sample(u).dtype == np.float32
    rect = D.RectangleSurface(*(np.float32(v) for v in ([0, 0, 0], [1, 0, 0], [0, 1, 0])))
    assert rect.sample(u).dtype == np.float32


def test_valid_unusual_input_still_works():
    """Inputs at the edge of the allowed ranges (not errors)."""
    assert D.UniformCone(-1.0).solid_angle == pytest.approx(4 * np.pi)
    assert D.PhongLobe(0).exponent == 0.0
    assert D.LinearInterval(0, 1, 0, 2).f0 == 0.0
    assert D.TruncatedNormal(0, 1, -np.inf, 0.0).b == 0.0
    assert D.Mixture([D.UniformSphere(), D.UniformSphere()], [0, 1]).probabilities.tolist() == [0.0, 1.0]
    # weights whose sum overflows are rescaled exactly
    p = D.PiecewiseConstant1D([1e308, 1e308, 0.0])
    assert np.allclose(p.pdf([[0.1], [0.5], [0.9]]), [1.5, 1.5, 0.0])
    mix = D.Mixture([D.UniformInterval(), D.UniformInterval(1, 2)], [1e308, 1e308])
    assert mix.probabilities.tolist() == [0.5, 0.5]
    # batched, almost unit (float32-rounded) normals are unit vectors to the frame check
    n = np.float32([0.267261, 0.534522, 0.801784])
    assert D.Frame(n).n.dtype == np.float32
    # an empty batch of points is not an error
    assert D.UniformSphere().pdf(np.zeros((0, 3))).shape == (0,)
    assert D.AliasTable([1.0]).sample(np.zeros((0, 1))).shape == (0,)
