"""Tests for vrlab.distributions.surfaces: light surfaces and the directions they induce.

Area sampling is checked with the chi-square harness on the matching charts.  The
solid-angle pdfs have silhouettes (discontinuities for polygons, integrable 1/sqrt
singularities for smooth closed shapes), where per-cell Gauss quadrature is poor, so:
* rectangle and box directions use an aimed ``CapChart`` with expected counts from a
  refined quadrature (``_chi2_refined``: cells split ``sub`` x ``sub``);
* ellipsoid/sphere directions use ``vrlab.testing.EllipsoidViewChart``, which maps the silhouette
  of the ellipsoid onto the chart's edge and cancels the singularity, so
  ``pdf * jacobian`` is smooth.
"""
from __future__ import annotations

import decimal
from decimal import Decimal as Dec

import numpy as np
import pytest

from vrlab._rng import as_generator
from conftest import InFrame
from vrlab.distributions.frames import to_world
from vrlab.distributions.solid_angle import LightSample, SolidAngleFromArea, SphereCone
from vrlab.distributions.quadrics import (EllipsoidSurface, SphereSurface, unit_sphere_hit, unit_sphere_hits,
                                          unit_sphere_roots)
from vrlab.distributions.surfaces import BoxSurface, DiskSurface, RectangleSurface, Surface
from vrlab.testing import (AtlasChart, CapChart, EllipsoidChart, ParallelogramChart, SphereChart,
                           assert_gof, box_surface_chart, chi2_gof, integrate)
from vrlab.testing.ellipsoid_view import EllipsoidViewChart
from vrlab.testing.chisquare import cell_integrals, histogram, pooled_chi2
from vrlab.experiments.light_surfaces import FirstHitOnly   # the one-hit bug the lecture warns about


def _rotation(axis, angle):
    """Rodrigues rotation matrix."""
    k = np.asarray(axis, float) / np.linalg.norm(axis)
    K = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + np.sin(angle) * K + (1 - np.cos(angle)) * K @ K


R_BOX = _rotation([1, 2, 3], 0.8)
R_ELL = _rotation([-1, 0.5, 2], 1.1)
M_ELL = np.array([[1.0, 0.4, 0.1], [0.2, 2.0, 0.3], [0.0, 0.5, 0.7]])  # non-diagonal, det > 0
REF = np.array([3.0, 4.0, 6.0])                                          # outside every shape below


def rect():
    return RectangleSurface([0.0, 0.0, 1.0], [1.0, 0.0, 0.2], [0.3, 1.0, 0.0])


def box():
    return BoxSurface([0.3, -0.2, 1.0], [0.5, 1.0, 2.0], R_BOX)


def ellipsoid():
    return EllipsoidSurface([1.0, 2.0, 3.0], M_ELL)


C_DISK, A1_DISK, A2_DISK = [0.2, -0.1, 1.0], [1.0, 0.2, 0.1], [0.3, 0.8, -0.2]   # sheared: an ellipse


def disk():
    return DiskSurface(C_DISK, A1_DISK, A2_DISK)


def disk_polar():
    return DiskSurface(C_DISK, A1_DISK, A2_DISK, method="polar")


def sphere():
    return SphereSurface([0.0, 0.0, 0.0], 2.0)


# an open cylinder: radius 0.6 about the axis (0.3, 0.8, 0.52)-ish of length 1.7
_R3 = np.linalg.qr(np.array([[0.3, 1.0, 0.2], [0.8, -0.1, 0.5], [0.52, 0.3, -0.9]]))[0]
C_CYL, A1_CYL, A2_CYL, A3_CYL = np.array([0.1, 0.2, -0.3]), 0.6 * _R3[:, 0], 0.6 * _R3[:, 1], 1.7 * _R3[:, 2]


def cylinder():
    from vrlab.distributions import CylinderSurface

    return CylinderSurface(C_CYL, A1_CYL, A2_CYL, A3_CYL)


class _CylinderChart:
    """The tube c + cos(2 pi t) a1 + sin(2 pi t) a2 + s a3, (s, t) in [0, 1)^2; area element
    |dx/ds x dx/dt| = |a3 x 2 pi (-sin a1 + cos a2)| (2 pi r h)."""

    p, dim_x = 2, 3

    def __init__(self, c, a1, a2, a3):
        self.c, self.m = np.asarray(c, float), np.stack([a1, a2, a3], 1)

    def to_param(self, x):
        q = (np.asarray(x) - self.c) @ np.linalg.inv(self.m).T
        return np.stack([q[..., 2], np.mod(np.arctan2(q[..., 1], q[..., 0]) / (2 * np.pi), 1)], -1)

    def from_param(self, s):
        phi = 2 * np.pi * s[..., 1:2]
        return self.c + np.cos(phi) * self.m[:, 0] + np.sin(phi) * self.m[:, 1] + s[..., 0:1] * self.m[:, 2]

    def jacobian(self, s):
        phi = 2 * np.pi * s[..., 1:2]
        dt = 2 * np.pi * (-np.sin(phi) * self.m[:, 0] + np.cos(phi) * self.m[:, 1])
        return np.linalg.norm(np.cross(np.broadcast_to(self.m[:, 2], dt.shape), dt), axis=-1)


def ones(x):
    return np.ones(np.shape(x)[:-1])


# ----------------------------------------------------------------------------- test helpers



def _aimed(surface, ref, margin=1.01):
    """Axis from ``ref`` to the bounding sphere's center and a cap z_min that contains it."""
    c, r = surface.bounding_sphere()
    v = c - ref
    d = np.linalg.norm(v)
    z = np.sqrt(1.0 - (r / d) ** 2)
    return v / d, 1.0 - (1.0 - z) * margin


def _chi2_refined(dist, chart, bins, *, sub=8, n=100_000, rng=0, quad=4, name="refined"):
    """Chi-square with expected counts integrated on a grid refined ``sub`` times per axis.

    Cells whose quadrature nodes all miss the support (thin slivers at a silhouette) get a
    tiny floor instead of exactly 0, so a legitimate sample there is pooled rather than
    failing outright; samples where the pdf is really 0 are caught by the caller's
    ``pdf(sample) > 0`` check.
    """
    u = as_generator(rng).random((n, dist.dim_u))
    x = dist.sample(u)
    counts, outside = histogram(chart.to_param(x), bins)
    fine = cell_integrals(dist.pdf, chart, (bins[0] * sub, bins[1] * sub), quad)
    expected = n * fine.reshape(bins[0], sub, bins[1], sub).sum(axis=(1, 3))
    expected = np.maximum(expected, 1e-9 * n / expected.size)
    res = pooled_chi2(counts, expected, 5.0, name)
    if outside:
        res.outside += outside
        res.pvalue = 0.0
    return res, x


class _DiskChart:
    """The disk c + sqrt(s) (cos(2 pi t) a1 + sin(2 pi t) a2); area element |dx/ds x dx/dt|,
    here from the two derivatives (pi |a1 x a2| by hand)."""

    p, dim_x = 2, 3

    def __init__(self, center, a1, a2):
        self.c, self.a = np.asarray(center, float), np.stack([a1, a2]).astype(float)

    def to_param(self, x):
        pq = (np.asarray(x) - self.c) @ np.linalg.pinv(self.a)
        return np.stack([np.sum(pq * pq, -1), np.mod(np.arctan2(pq[..., 1], pq[..., 0]) / (2 * np.pi), 1)], -1)

    def _dirs(self, s):
        phi = 2 * np.pi * s[..., 1:2]
        return np.cos(phi) * self.a[0] + np.sin(phi) * self.a[1], -np.sin(phi) * self.a[0] + np.cos(phi) * self.a[1]

    def from_param(self, s):
        return self.c + np.sqrt(s[..., 0:1]) * self._dirs(s)[0]

    def jacobian(self, s):
        radial, tangent = self._dirs(s)          # dx/ds = radial / (2 sqrt s), dx/dt = 2 pi sqrt(s) tangent
        return np.linalg.norm(np.cross(radial / 2, 2 * np.pi * tangent), axis=-1)


class _WrongDisk(DiskSurface):
    """Disk density 1 / (pi |a1| |a2|): forgets the shear (right only for perpendicular axes)."""

    def pdf(self, x):
        return np.full(np.shape(x)[:-1], 1.0 / (np.pi * np.linalg.norm(self.axis1) * np.linalg.norm(self.axis2)))


class _WrongEllipsoid(EllipsoidSurface):
    """Ellipsoid density without the ||M^-T n|| factor: 1 / (4 pi |det M|)."""

    def pdf(self, x):
        return np.full(np.shape(x)[:-1], 1.0 / (4 * np.pi * self.abs_det))


def _parallelepiped_chart(center, L):
    charts = []
    for axis in range(3):
        i, j = [a for a in range(3) if a != axis]
        for sign in (-1.0, 1.0):
            corner = center + sign * L[:, axis] - L[:, i] - L[:, j]
            charts.append(ParallelogramChart(corner, 2 * L[:, i], 2 * L[:, j]))
    return AtlasChart(charts)


L_SHEAR = np.array([[0.6, 0.3, 0.0], [0.0, 1.0, 0.4], [0.2, 0.0, 1.5]])
C_SHEAR = np.array([0.5, 0.0, -1.0])


def sheared_box():
    M = np.eye(4)
    M[:3, :3], M[:3, 3] = L_SHEAR, C_SHEAR
    return BoxSurface.from_matrix(M)


def mesh_box():
    """``box()`` as a triangle mesh (12 triangles, outward winding): the same uniform density."""
    from vrlab.distributions import TriangleMeshSurface

    q = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], float)
    corners = np.array([0.3, -0.2, 1.0]) + (q * [0.5, 1.0, 2.0]) @ R_BOX.T
    quads = np.array([[0, 1, 3, 2], [4, 6, 7, 5], [0, 4, 5, 1], [2, 3, 7, 6], [0, 2, 6, 4], [1, 5, 7, 3]])
    faces = np.concatenate([quads[:, [0, 1, 2]], quads[:, [0, 2, 3]]])
    tri = corners[faces]
    out = np.sum(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]) * (tri.mean(1) - corners.mean(0)), -1) > 0
    return TriangleMeshSurface(corners, np.where(out[:, None], faces, faces[:, ::-1]))


# ----------------------------------------------------------------------------- area sampling

AREA_CASES = [
    ("rectangle", rect,
     lambda: ParallelogramChart([0.0, 0.0, 1.0], [1.0, 0.0, 0.2], [0.3, 1.0, 0.0]), (16, 16)),
    ("box", box, lambda: box_surface_chart([0.3, -0.2, 1.0], [0.5, 1.0, 2.0], R_BOX), (36, 12)),
    ("parallelepiped", sheared_box, lambda: _parallelepiped_chart(C_SHEAR, L_SHEAR), (36, 12)),
    ("ellipsoid", ellipsoid, lambda: EllipsoidChart([1.0, 2.0, 3.0], M_ELL), (20, 20)),
    ("sphere", sphere, lambda: EllipsoidChart([0.0, 0.0, 0.0], 2.0 * np.eye(3)), (20, 20)),
    ("disk", disk, lambda: _DiskChart(C_DISK, A1_DISK, A2_DISK), (16, 24)),
    ("disk-polar", disk_polar, lambda: _DiskChart(C_DISK, A1_DISK, A2_DISK), (16, 24)),
    ("cylinder", cylinder, lambda: _CylinderChart(C_CYL, A1_CYL, A2_CYL, A3_CYL), (12, 24)),
    ("mesh-box", mesh_box, lambda: box_surface_chart([0.3, -0.2, 1.0], [0.5, 1.0, 2.0], R_BOX), (36, 12)),
]


def test_area_sampling_chi_square():
    results = [chi2_gof(make(), chart(), bins, n=100_000, rng=10 + k, name=name)
               for k, (name, make, chart, bins) in enumerate(AREA_CASES)]
    assert_gof(results, alpha=0.01)


@pytest.mark.parametrize("name,make,chart,bins", AREA_CASES, ids=[c[0] for c in AREA_CASES])
def test_area_pdf_integrates_to_one_and_area_is_exact(name, make, chart, bins):
    surface, ch = make(), chart()
    fine = (bins[0] * 2, bins[1] * 2)
    assert integrate(surface.pdf, ch, fine) == pytest.approx(1.0, abs=1e-9)
    assert integrate(ones, ch, fine) == pytest.approx(surface.area, rel=1e-9)


def test_wrong_ellipsoid_pdf_fails_chi_square():
    wrong = _WrongEllipsoid([1.0, 2.0, 3.0], M_ELL)
    res = chi2_gof(wrong, EllipsoidChart([1.0, 2.0, 3.0], M_ELL), (20, 20), n=100_000, rng=3)
    with pytest.raises(AssertionError):
        assert_gof(res)


def test_wrong_disk_pdf_fails_chi_square():
    wrong = _WrongDisk(C_DISK, A1_DISK, A2_DISK)
    res = chi2_gof(wrong, _DiskChart(C_DISK, A1_DISK, A2_DISK), (16, 24), n=100_000, rng=3)
    with pytest.raises(AssertionError):
        assert_gof(res)


def test_wrong_mesh_triangle_choice_fails_chi_square():
    """Triangles of the box mesh chosen uniformly (1/12 each), not by area, with p = 1/A claimed."""
    class Uniform(type(mesh_box())):
        def sample(self, u):
            u = np.asarray(u, float)
            k = np.minimum((u[..., 0] * 12).astype(int), 11)
            r = u[..., 0] * 12 - k
            b1, b2 = np.sqrt(r) * (1 - u[..., 1]), np.sqrt(r) * u[..., 1]
            return self.v0[k] + b1[..., None] * self.e1[k] + b2[..., None] * self.e2[k]

    m = mesh_box()
    res = chi2_gof(Uniform(m.vertices, m.faces), box_surface_chart([0.3, -0.2, 1.0], [0.5, 1.0, 2.0], R_BOX),
                   (36, 12), n=100_000, rng=3)
    with pytest.raises(AssertionError):
        assert_gof(res)


def test_wrong_cylinder_pdf_fails_chi_square():
    """Uniform in (z, phi) is uniform by area only because the axes are orthogonal: sampling z
    by u1^2 instead (a density wrong by 2 z) must fail."""
    class Wrong(type(cylinder())):
        def sample(self, u):
            u = np.asarray(u, float)
            return super().sample(np.stack([np.sqrt(u[..., 0]), u[..., 1]], -1))

    res = chi2_gof(Wrong(C_CYL, A1_CYL, A2_CYL, A3_CYL), _CylinderChart(C_CYL, A1_CYL, A2_CYL, A3_CYL), (12, 24),
                   n=100_000, rng=3)
    with pytest.raises(AssertionError):
        assert_gof(res)


def test_cylinder_intersect_normal_and_invert():
    s = cylinder()
    u = np.random.default_rng(4).random((500, 2))
    x = s.sample(u)
    np.testing.assert_allclose(s.invert(x), u, atol=1e-12)
    n = s.normal(x)
    radial = x - C_CYL - ((x - C_CYL) @ _R3[:, 2])[:, None] * _R3[:, 2]
    np.testing.assert_allclose(n, radial / np.linalg.norm(radial, axis=-1, keepdims=True), atol=1e-12)
    o = x + 3.0 * n                                     # rays from outside towards the sampled points
    t = s.intersect(o, -n)
    assert np.all(np.isfinite(t[:, 0]))
    np.testing.assert_allclose(t[:, 0], 3.0, rtol=1e-9)    # the first hit is the sampled point
    with pytest.raises(ValueError, match="a1"):
        type(s)(C_CYL, A1_CYL, A1_CYL, A3_CYL)              # the axes must be orthogonal


def test_samples_lie_on_the_surface():
    u = as_generator(5).random((20_000, 2))
    r = rect()
    x = r.sample(u)
    assert np.all(np.abs((x - r.corner) @ r.unit_normal) <= 1e-12 * np.sqrt(r.area))
    st = r.invert(x)
    assert np.all((st >= -1e-12) & (st <= 1 + 1e-12))

    for b, L, c in [(box(), R_BOX * [0.5, 1.0, 2.0], box().center), (sheared_box(), L_SHEAR, C_SHEAR)]:
        q = (b.sample(u) - c) @ np.linalg.inv(L).T
        assert np.allclose(np.max(np.abs(q), -1), 1.0, rtol=0, atol=1e-12)
        # every face is used, in proportion to its area (checked by chi-square above)
        assert set(np.unique(b.face(b.sample(u)))) == set(range(6))

    e = ellipsoid()
    d = (e.sample(u) - e.center) @ np.linalg.inv(M_ELL).T
    assert np.allclose(np.linalg.norm(d, axis=-1), 1.0, rtol=0, atol=1e-12)
    s = sphere()
    assert np.allclose(np.linalg.norm(s.sample(u) - s.center, axis=-1), 2.0, rtol=1e-12, atol=0)


@pytest.mark.parametrize("make", [rect, box, sheared_box, ellipsoid, sphere, disk, disk_polar])
def test_invert_undoes_sample(make):
    surface = make()
    u = as_generator(6).random((5_000, 2))
    assert np.allclose(surface.invert(surface.sample(u)), u, rtol=0, atol=1e-10)


def test_closed_form_densities():
    s = sphere()
    x = s.sample(as_generator(1).random((10, 2)))
    assert np.allclose(s.pdf(x), 1.0 / (4 * np.pi * 4.0), rtol=1e-14)
    assert s.area == pytest.approx(16 * np.pi)

    a, b, c = 1.5, 0.7, 2.5
    center = np.array([0.2, -1.0, 3.0])
    e = EllipsoidSurface(center, np.diag([a, b, c]))
    poles = center + np.array([[a, 0, 0], [-a, 0, 0], [0, b, 0], [0, 0, c], [0, 0, -c]])
    expect = 1 / (4 * np.pi * np.array([b * c, b * c, a * c, a * b, a * b]))
    assert np.allclose(e.pdf(poles), expect, rtol=1e-13)
    # same ellipsoid rotated: the density follows the poles
    er = EllipsoidSurface.from_radii(center, [a, b, c], R_ELL)
    rotated_poles = center + np.diag([a, b, c]) @ R_ELL.T
    assert np.allclose(er.pdf(rotated_poles), 1 / (4 * np.pi * np.array([b * c, a * c, a * b])), rtol=1e-12)
    # sphere as an ellipsoid M = r I agrees with SphereSurface
    e2 = EllipsoidSurface([0, 0, 0], 2.0 * np.eye(3))
    assert np.allclose(e2.pdf(x), s.pdf(x), rtol=1e-13)
    assert e2.area == pytest.approx(s.area, rel=1e-13)
    # box: 1 / total area, faces (4 h_i h_j)
    bx = BoxSurface([0, 0, 0], [0.5, 1.0, 2.0])
    assert bx.area == pytest.approx(8 * (0.5 * 1.0 + 0.5 * 2.0 + 1.0 * 2.0))
    assert np.allclose(bx.face_probs, np.repeat([2.0, 1.0, 0.5], 2) / 7.0)


def test_normals():
    u = as_generator(2).random((2_000, 2))
    for make in [box, sheared_box, ellipsoid, sphere]:
        s = make()
        x = s.sample(u)
        n = s.normal(x)
        assert np.allclose(np.linalg.norm(n, axis=-1), 1.0)
        assert np.all(np.sum((x - s.center) * n, -1) > 0)          # outward
    # ellipsoid normal is the gradient of |M^-1 (x - c)|^2
    e = ellipsoid()
    x = e.sample(u[:50])
    Minv = np.linalg.inv(M_ELL)
    f = lambda p: np.sum(((p - e.center) @ Minv.T) ** 2, -1)  # noqa: E731
    h = 1e-6
    grad = np.stack([(f(x + h * np.eye(3)[k]) - f(x - h * np.eye(3)[k])) / (2 * h) for k in range(3)], -1)
    assert np.allclose(e.normal(x), grad / np.linalg.norm(grad, axis=-1, keepdims=True), atol=1e-7)
    # box normals are perpendicular to the face edges
    b = box()
    x = b.sample(u)
    k = b.face(x)
    assert np.allclose(np.sum(b.normal(x) * b._e1[k], -1), 0, atol=1e-12)
    assert np.allclose(np.sum(b.normal(x) * b._e2[k], -1), 0, atol=1e-12)
    r = rect()
    assert np.allclose(r.normal(r.sample(u[:3])), np.cross(r.edge1, r.edge2) / r.area)
    dk = disk()
    n = np.cross(A1_DISK, A2_DISK)
    assert np.allclose(dk.normal(dk.sample(u[:3])), n / np.linalg.norm(n))
    assert np.allclose((dk.sample(u) - C_DISK) @ n, 0, atol=1e-12)               # in the plane


# ----------------------------------------------------------------------------- intersect

def test_intersect_known_values():
    s = SphereSurface([0, 0, 0], 1.0)
    t = s.intersect([0, 0, -5], [[0, 0, 1], [0, 0, -1], [0, 1, 0]])
    assert np.allclose(t[0], [4, 6]) and np.all(np.isinf(t[1:]))
    t = s.intersect([0, 0, 0.5], [0, 0, 1])                      # from inside: one hit
    assert np.allclose(t[0], 0.5) and np.isinf(t[1])
    assert np.allclose(s.intersect([0, 0, -5], [0, 0, 2]), [2, 3])  # t in units of |direction|

    b = BoxSurface([0, 0, 0], [1, 2, 3])
    assert np.allclose(b.intersect([-5, 0, 0], [1, 0, 0]), [4, 6])
    t = b.intersect([0, 0, 0], [0, 0, 1])                         # from inside: one hit
    assert np.allclose(t[0], 3) and np.isinf(t[1])
    assert np.all(np.isinf(b.intersect([-5, 0, 0], [0, 1, 0])))

    r = RectangleSurface.from_matrix(np.eye(4))
    assert r.intersect([0.5, 0.5, 2], [0, 0, -1]).shape == (1,)
    assert np.allclose(r.intersect([[0.5, 0.5, 2], [0.5, 0.5, -2]], [0, 0, -1]), [[2], [np.inf]])
    assert np.isinf(r.intersect([1.5, 0, 2], [0, 0, -1])[0])

    e = EllipsoidSurface.from_radii([0, 0, 0], [1, 2, 3])
    assert np.allclose(e.intersect([0, 0, -10], [0, 0, 1]), [7, 13])
    assert np.allclose(e.intersect([0, -10, 0], [0, 1, 0]), [8, 12])

    dk = DiskSurface([0, 0, 1], [2, 0, 0], [0, 0.5, 0])                       # ellipse x^2/4 + 4 y^2 <= 1
    t = dk.intersect([[1.9, 0, 3], [0, 0.45, 3], [0, 0.55, 3], [1.9, 0.2, 3]], [0, 0, -1])
    assert np.allclose(t[:2, 0], 2) and np.all(np.isinf(t[2:, 0]))
    assert dk.bounding_sphere()[1] == pytest.approx(2.0)
    sheared = DiskSurface([0, 0, 0], [1, 0, 0], [1, 0.2, 0])                   # semi-major axis > |a2|
    far = sheared.sample(np.array([[0.5 + 1e-9, 0.5 + 0.125]]))                # concentric: the diagonal
    assert np.linalg.norm(far) <= sheared.bounding_sphere()[1] + 1e-12
    assert sheared.bounding_sphere()[1] > np.linalg.norm([1, 0.2, 0]) * 1.3


def test_unit_sphere_roots_known_values():
    o = np.array([[0, 0, -5], [0, 0, -5], [0, 0, 0.5], [0, 1, -5], [0, 0, 1 + 1e-12], [0, 0, -5]], float)
    d = np.array([[0, 0, 1], [0, 1, 0], [0, 0, 1], [0, 0, 1], [0, 0, -1], [0, 0, 0]], float)
    near, far = unit_sphere_roots(o, d)
    # through the centre, a miss, from inside, tangent (double root), starting 1e-12 outside
    # (the small root c/q = 1e-12 without cancellation), and d = 0 (no line)
    np.testing.assert_allclose(near[[0, 2, 3]], [4, -1.5, 5])
    np.testing.assert_allclose(far[[0, 2, 3]], [6, 0.5, 5])
    gap = o[4, 2] - 1.0                                                      # exact (Sterbenz): ~1e-12
    assert near[4] == pytest.approx(gap, rel=1e-12, abs=0) and far[4] == pytest.approx(2.0)
    assert np.all(np.isinf(near[[1, 5]])) and np.all(np.isinf(far[[1, 5]]))
    np.testing.assert_allclose(unit_sphere_hit(o, d, 0.0), [4, np.inf, 0.5, 5, gap, np.inf], rtol=1e-12)
    np.testing.assert_allclose(unit_sphere_hit(o, d, 4.5), [6, np.inf, np.inf, 5, np.inf, np.inf])
    t_min = np.array([0, 0, 0, 0, 1e-9, 0.0])                                 # per ray
    hits = unit_sphere_hits(o, d, t_min)
    np.testing.assert_allclose(hits, [[4, 6], [np.inf] * 2, [0.5, np.inf], [5, 5], [2, np.inf], [np.inf] * 2])
    # a start 1.5e-8 outside, inputs whose a, b, c are exact in float64: the stable root c / q
    # is right to rounding, the textbook (-b - sqrt(b^2 - a c)) / a is 7e-9 off (cancellation)
    o1, d1 = np.array([1 + 2.0**-26, 0.0, 0.0]), np.array([-1.0, 2.0**-4, 0.0])
    with decimal.localcontext() as ctx:
        ctx.prec = 50
        a, b, c = (sum(Dec(x) * Dec(y) for x, y in zip(u, v)) for u, v in ((d1, d1), (o1, d1), (o1, o1)))
        exact = float((c - 1) / (-(b - (b * b - a * (c - 1)).sqrt())))      # c / q, b < 0
    assert unit_sphere_roots(o1, d1)[0] == pytest.approx(exact, rel=1e-12, abs=0)
    assert unit_sphere_hit(o.astype(np.float32), d.astype(np.float32), 0.0).dtype == np.float32
    np.testing.assert_allclose(unit_sphere_hit(o, 2 * d, 0.0)[0], 2.0)       # t in units of |d|


@pytest.mark.parametrize("make", [rect, box, sheared_box, ellipsoid, sphere, disk])
def test_intersect_finds_the_sampled_point_and_broadcasts(make):
    s = make()
    u = as_generator(8).random((4, 500, 2))
    y = s.sample(u)
    v = y - REF
    dist = np.linalg.norm(v, axis=-1)
    t = s.intersect(REF, v / dist[..., None])
    assert t.shape == (4, 500, s.max_hits)
    assert np.all(np.min(np.abs(t - dist[..., None]), -1) <= 1e-9 * dist)
    hits = np.isfinite(t)
    pts = REF + np.where(hits, t, 0)[..., None] * (v / dist[..., None])[..., None, :]
    q = s.invert(pts[hits])                                       # back onto the surface chart
    assert np.allclose(s.sample(q), pts[hits], atol=1e-9)
    assert np.all(np.diff(t, axis=-1) >= 0) if s.max_hits > 1 else True


# ----------------------------------------------------------------------------- directions

def test_rectangle_and_box_directions_chi_square():
    results = []
    for k, (make, power) in enumerate([(rect, 1), (rect, 2), (box, 1), (box, 2), (sheared_box, 2), (disk, 1),
                                       (disk, 2), (mesh_box, 2)]):
        d = SolidAngleFromArea(make(), REF)
        axis, z_min = _aimed(d.surface, REF)
        res, w = _chi2_refined(InFrame(d, axis), CapChart(z_min, power), (16, 16), rng=20 + k,
                               name=f"{make.__name__} power={power}")
        assert np.all(d.pdf(to_world(w, axis)) > 0)
        results.append(res)
    assert_gof(results, alpha=0.01)


def test_ellipsoid_and_sphere_directions_chi_square():
    results = []
    for k, (make, M) in enumerate([(ellipsoid, M_ELL), (sphere, 2.0 * np.eye(3))]):
        s = make()
        d = s.solid_angle_from(REF)
        chart = EllipsoidViewChart(s.center, M, REF)
        results.append(chi2_gof(d, chart, (16, 16), n=100_000, rng=30 + k, name=make.__name__))
        # also seen from another side, closer
        ref2 = s.center + np.array([-1.0, 2.5, -2.0]) * 1.3
        chart2 = EllipsoidViewChart(s.center, M, ref2)
        results.append(chi2_gof(s.solid_angle_from(ref2), chart2, (16, 16), n=100_000, rng=40 + k,
                                name=make.__name__ + " near"))
    assert_gof(results, alpha=0.01)


@pytest.mark.parametrize("make", [rect, box, sheared_box, ellipsoid, sphere, disk, mesh_box])
def test_solid_angle_pdf_integrates_to_one(make):
    s = make()
    d = s.solid_angle_from(REF)
    axis, z_min = _aimed(s, REF)
    # an aimed cap, independent of the shape; silhouettes limit the accuracy (jumps for
    # polygons, 1/sqrt singularities for smooth shapes), the view chart below is exact
    smooth = isinstance(s, (EllipsoidSurface, SphereSurface))
    total = float(cell_integrals(InFrame(d, axis).pdf, CapChart(z_min, 1), (128, 128), 4).sum())
    assert total == pytest.approx(1.0, abs=2e-2 if smooth else 3e-3)
    if smooth:
        M = M_ELL if isinstance(s, EllipsoidSurface) else 2.0 * np.eye(3)
        view = EllipsoidViewChart(s.center, M, REF)
        assert integrate(d.pdf, view, 32) == pytest.approx(1.0, abs=1e-9)
        # the view chart covers the directions that hit the shape: its solid angle is right
        hits = lambda w: np.isfinite(s.intersect(REF, to_world(w, axis))[..., 0])  # noqa: E731
        omega = float(cell_integrals(hits, CapChart(z_min, 1), (256, 256), 2).sum())
        assert integrate(ones, view, 16) == pytest.approx(omega, rel=2e-3)
        if isinstance(s, SphereSurface):
            D = np.linalg.norm(REF - s.center)
            cone = 2 * np.pi * (1 - np.sqrt(1 - 4 / D**2))
            assert integrate(ones, view, 16) == pytest.approx(cone, rel=1e-12)
    # directions that miss have density 0
    w = -(s.bounding_sphere()[0] - REF)
    assert d.pdf(w / np.linalg.norm(w)) == 0.0


def test_two_hits_are_needed():
    # sphere radius r at distance D: the first hit alone carries the visible cap's mass,
    # (1 - r/D)/2, the second hit the rest; a one-hit pdf fails chi-square
    s = sphere()
    D = np.linalg.norm(REF)
    chart = EllipsoidViewChart(s.center, 2.0 * np.eye(3), REF)
    one = SolidAngleFromArea(FirstHitOnly(s), REF)
    both = s.solid_angle_from(REF)
    assert integrate(one.pdf, chart, 32) == pytest.approx(0.5 * (1 - 2.0 / D), abs=1e-9)
    assert integrate(both.pdf, chart, 32) == pytest.approx(1.0, abs=1e-9)
    e = ellipsoid()
    echart = EllipsoidViewChart(e.center, M_ELL, REF)
    first = integrate(SolidAngleFromArea(FirstHitOnly(e), REF).pdf, echart, 32)
    assert 0.3 < first < 0.5
    for surf, ch in [(s, chart), (e, echart)]:
        res = chi2_gof(SolidAngleFromArea(FirstHitOnly(surf), REF), ch, (16, 16), n=100_000, rng=4)
        with pytest.raises(AssertionError):
            assert_gof(res)
    # the box too: first-hit-only integrates well below 1
    b = box()
    axis, z_min = _aimed(b, REF)
    bo = InFrame(SolidAngleFromArea(FirstHitOnly(b), REF), axis)
    assert float(cell_integrals(bo.pdf, CapChart(z_min, 1), (64, 64), 4).sum()) < 0.6


def test_wrong_solid_angle_conversion_fails():
    class NoCos(SolidAngleFromArea):  # forgets the 1/|cos| of the area-to-solid-angle Jacobian
        def pdf(self, w):
            t = self.surface.intersect(self.ref, w)
            t = np.where(np.isfinite(t), t, 0.0)
            return np.sum(self.surface.pdf(self.ref + t[..., None] * w[..., None, :]) * t * t * (t > 0), -1)

    d = NoCos(rect(), REF)
    axis, z_min = _aimed(d.surface, REF)
    res, _ = _chi2_refined(InFrame(d, axis), CapChart(z_min, 2), (16, 16), rng=1)
    with pytest.raises(AssertionError):
        assert_gof(res)


# ----------------------------------------------------------------------------- irradiance

def _polygon_irradiance(vertices, ref, n):
    """Lambert's formula: int over a polygon's directions of max(0, w.n) (polygon above the horizon)."""
    r = vertices - ref
    r = r / np.linalg.norm(r, axis=-1, keepdims=True)
    total = 0.0
    for i in range(len(r)):
        a, b = r[i], r[(i + 1) % len(r)]
        cr = np.cross(a, b)
        total += np.arctan2(np.linalg.norm(cr), a @ b) * (cr / np.linalg.norm(cr)) @ n
    return abs(0.5 * total)


def _quadrature_irradiance(surface, ref, n_ref, m):
    """Midpoint rule on an aimed cap: int 1[ray hits] max(0, w.n) dw, and its change from 2m/3."""
    axis, z_min = _aimed(surface, ref)
    chart = CapChart(z_min, 1)

    def q(m):
        g = (np.arange(m) + 0.5) / m
        s = np.stack(np.meshgrid(g, g, indexing="ij"), -1)
        w = to_world(chart.from_param(s), axis)
        hit = np.isfinite(surface.intersect(ref, w)[..., 0])
        return float(np.sum(hit * np.clip(w @ n_ref, 0, None) * chart.jacobian(s)) / m**2)

    fine = q(m)
    return fine, abs(fine - q(2 * m // 3))  # 2/3: rows not aligned with the fine grid


IRRADIANCE_CASES = [
    ("rectangle", rect, np.array([-0.3, -0.5, -0.8])),
    ("box", box, np.array([-0.2, -0.6, -0.6])),
    ("ellipsoid", ellipsoid, np.array([-0.5, -0.3, -0.6])),
    ("sphere", sphere, np.array([-0.6, -0.8, -0.3])),
    ("disk", disk, np.array([-0.3, -0.5, -0.8])),
]


@pytest.mark.parametrize("name,make,n_ref", IRRADIANCE_CASES, ids=[c[0] for c in IRRADIANCE_CASES])
def test_irradiance_estimate_matches_quadrature(name, make, n_ref):
    """E = int_{w hits the light} max(0, w.n) dw (L = 1): each sampled w weighs cos/p(w),
    with p summed over both hits, since the integral is over directions, not points."""
    s = make()
    n_ref = n_ref / np.linalg.norm(n_ref)
    d = s.solid_angle_from(REF)
    w, p = d.sample_pdf(as_generator(50).random((200_000, 2)))
    f = np.clip(w @ n_ref, 0, None) / p
    est, se = f.mean(), f.std(ddof=1) / np.sqrt(len(f))
    quad, qerr = _quadrature_irradiance(s, REF, n_ref, 800)
    assert abs(est - quad) <= 4 * se + 2 * qerr + 1e-12, (est, se, quad, qerr)
    if name == "rectangle":
        verts = s.corner + np.array([[0, 0], [1, 0], [1, 1], [0, 1]]) @ np.stack([s.edge1, s.edge2])
        exact = _polygon_irradiance(verts, REF, n_ref)
        assert abs(est - exact) <= 4 * se
        assert abs(quad - exact) <= 2 * qerr + 1e-4
    if name == "sphere":
        D = np.linalg.norm(REF)
        exact = np.pi * (2.0 / D) ** 2 * (-REF / D) @ n_ref   # sphere fully above the horizon
        assert abs(est - exact) <= 4 * se
        cone = s.cone_from(REF)
        wc, pc = cone.sample_pdf(as_generator(51).random((200_000, 2)))
        fc = np.clip(wc @ n_ref, 0, None) / pc
        assert abs(fc.mean() - exact) <= 4 * fc.std(ddof=1) / np.sqrt(len(fc))


def test_disk_irradiance_on_axis_closed_form():
    """A circular disk of radius R seen on its axis from distance h: int cos dw = pi R^2 / (R^2 + h^2)."""
    R, h = 0.7, 1.5
    for method in DiskSurface.METHODS:
        dk = DiskSurface([0.0, 0.0, 0.0], [R, 0.0, 0.0], [0.0, R, 0.0], method=method)
        w, p = dk.solid_angle_from([0.0, 0.0, h]).sample_pdf(as_generator(53).random((200_000, 2)))
        f = -w[:, 2] / p
        exact = np.pi * R**2 / (R**2 + h**2)
        assert abs(f.mean() - exact) <= 4 * f.std(ddof=1) / np.sqrt(len(f))


def test_one_hit_irradiance_is_biased():
    s = sphere()
    n_ref = -REF / np.linalg.norm(REF)
    D = np.linalg.norm(REF)
    exact = np.pi * (2.0 / D) ** 2
    d = SolidAngleFromArea(FirstHitOnly(s), REF)
    u = as_generator(52).random((200_000, 2))
    w = d.sample(u)
    p = d.pdf(w)
    f = np.where(p > 0, np.clip(w @ n_ref, 0, None) / np.where(p > 0, p, 1), 0)
    assert abs(f.mean() - exact) > 10 * f.std(ddof=1) / np.sqrt(len(f))


# ----------------------------------------------------------------------------- batching

@pytest.mark.parametrize("make", [rect, box, ellipsoid, sphere, disk])
def test_batched_reference_points_match_one_at_a_time(make):
    s = make()
    rng = as_generator(60)
    refs = REF + rng.normal(size=(5, 3))
    u = rng.random((5, 300, 2))
    d = SolidAngleFromArea(s, refs[:, None, :])
    batch = d.sample_point(u)
    assert isinstance(batch, LightSample)
    assert batch.w.shape == (5, 300, 3) and batch.pdf.shape == (5, 300) and batch.dist.shape == (5, 300)
    for i in range(5):
        one = SolidAngleFromArea(s, refs[i]).sample_point(u[i])
        for a, b in zip(batch[:3], one[:3]):                     # w, y, dist: equal to rounding
            assert np.allclose(a[i], b, rtol=1e-12, atol=1e-14)
        # pdf = sum over the hits of p_A d^2 / |cos|: near the silhouette cos -> 0 and, for
        # closed shapes, the two hits merge (square root of a vanishing discriminant), so one
        # ulp in w or y (sin/cos of other array lengths) moves it by up to ~1e-7 relative
        # among these draws; a batching bug (wrong ref, wrong hit) moves it by far more
        assert np.allclose(batch.pdf[i], one.pdf, rtol=1e-6, atol=0)
    # pdf of arbitrary directions, broadcast (B, 1, 3) refs against (B, n, 3) directions
    assert np.allclose(d.pdf(batch.w), batch.pdf, rtol=1e-12)
    # sample_point: y is the sampled point at distance dist along w
    assert np.allclose(refs[:, None, :] + batch.dist[..., None] * batch.w, batch.y)
    if isinstance(s, SphereSurface):
        cone = s.cone_from(refs[:, None, :])
        wb, pb = cone.sample_pdf(u)
        for i in range(5):
            w1, p1 = s.cone_from(refs[i]).sample_pdf(u[i])
            assert np.allclose(wb[i], w1, rtol=1e-12, atol=1e-14) and np.allclose(pb[i], p1)


# ----------------------------------------------------------------------------- sphere cone

def test_sphere_cone_chi_square_and_normalisation():
    s = sphere()
    results = []
    for k, ref in enumerate([REF, np.array([0.5, -2.2, 0.4]), np.array([0.3, 0.2, -0.5])]):
        cone = s.cone_from(ref)
        assert isinstance(cone, SphereCone)
        chart = CapChart(float(cone.cos_max), 1)
        results.append(chi2_gof(InFrame(cone, cone.axis), chart, (16, 16), n=100_000, rng=70 + k))
        assert integrate(InFrame(cone, cone.axis).pdf, chart, 16) == pytest.approx(1.0, abs=1e-12)
        assert integrate(cone.pdf, SphereChart(), 128) == pytest.approx(1.0, abs=1e-2)
    assert bool(cone.inside)                       # the last ref is inside: uniform sphere
    assert np.allclose(cone.pdf(cone.sample(as_generator(0).random((10, 2)))), 1 / (4 * np.pi))
    assert_gof(results, alpha=0.01)


def test_sphere_cone_support_matches_area_sampling():
    s = sphere()
    cone = s.cone_from(REF)
    area = s.solid_angle_from(REF)
    axis, z_min = cone.axis, float(cone.cos_max)
    # directions uniform in a cap twice as wide as the cone
    g = as_generator(9).random((50_000, 2))
    w = to_world(CapChart(1 - 2 * (1 - z_min), 1).from_param(g), axis)
    pc, pa = cone.pdf(w), area.pdf(w)
    near = np.abs(1 - w @ axis - (1 - z_min)) < 1e-9
    assert np.array_equal((pc > 0)[~near], (pa > 0)[~near])
    assert 0.3 < np.mean(pc > 0) < 0.7
    # the cone formula: 1 / (2 pi (1 - cos_max)), cos_max = sqrt(1 - r^2/d^2)
    D = np.linalg.norm(REF)
    assert cone.pdf(axis) == pytest.approx(1 / (2 * np.pi * (1 - np.sqrt(1 - 4 / D**2))), rel=1e-12)


def test_sphere_cone_small_cone_and_sample_point():
    far = SphereCone([0, 0, 0], 1.0, [0, 0, 1e5])
    assert far.one_minus_cos == pytest.approx(0.5e-10, rel=1e-9)   # r^2 / (2 d^2), no cancellation
    u = as_generator(11).random((1000, 2))
    w = far.sample(u)
    assert np.all(far.pdf(w) > 0)
    assert np.allclose(far.invert(w), u, atol=1e-6)
    s = sphere()
    for ref in [REF, np.array([0.3, 0.2, -0.5])]:                 # outside, inside
        cone = s.cone_from(ref)
        ls = cone.sample_point(u)
        assert np.allclose(np.linalg.norm(ls.y, axis=-1), 2.0, rtol=1e-9)
        assert np.allclose(ls.dist, s.intersect(ref, ls.w)[..., 0], rtol=1e-9)
        assert np.allclose(cone.invert(ls.w), u, atol=1e-9)


# ----------------------------------------------------------------------------- constructors

def test_from_matrix_follows_mitsuba():
    r = RectangleSurface.from_matrix(np.eye(4))
    assert np.allclose(r.corner, [-1, -1, 0]) and r.area == pytest.approx(4)
    assert np.allclose(r.unit_normal, [0, 0, 1])
    M = np.eye(4)
    M[:3, :3] = R_ELL @ np.diag([2.0, 0.5, 3.0])
    M[:3, 3] = [1, 2, 3]
    r = RectangleSurface.from_matrix(M)
    assert np.allclose(r.center, [1, 2, 3]) and r.area == pytest.approx(4.0)
    n_mitsuba = np.linalg.inv(M[:3, :3]).T @ [0, 0, 1]
    assert np.allclose(r.unit_normal, n_mitsuba / np.linalg.norm(n_mitsuba))
    mirror = M.copy()
    mirror[:3, 0] *= -1                                            # det < 0
    rm = RectangleSurface.from_matrix(mirror)
    n_mitsuba = np.linalg.inv(mirror[:3, :3]).T @ [0, 0, 1]
    assert np.allclose(rm.unit_normal, n_mitsuba / np.linalg.norm(n_mitsuba))
    assert np.allclose(RectangleSurface.from_matrix(M, flip_normals=True).unit_normal, -r.unit_normal)

    B = np.eye(4)
    B[:3, :3] = R_BOX @ np.diag([0.5, 1.0, 2.0])
    B[:3, 3] = [0.3, -0.2, 1.0]
    u = as_generator(3).random((100, 2))
    assert np.allclose(BoxSurface.from_matrix(B).sample(u), box().sample(u))
    E = np.eye(4)
    E[:3, :3], E[:3, 3] = M_ELL, [1.0, 2.0, 3.0]
    assert np.allclose(EllipsoidSurface.from_matrix(E).sample(u), ellipsoid().sample(u))
    assert isinstance(box(), Surface) and box().measure == "area"


@pytest.mark.parametrize("build,arg", [
    (lambda: SphereSurface([0, 0, 0], 0.0), "radius"),
    (lambda: SphereSurface([0, 0], 1.0), "center"),
    (lambda: SphereSurface([0, 0, np.nan], 1.0), "center"),
    (lambda: EllipsoidSurface([0, 0, 0], np.diag([1.0, 1.0, 0.0])), "matrix"),
    (lambda: EllipsoidSurface([0, 0, 0], np.eye(2)), "matrix"),
    (lambda: EllipsoidSurface.from_radii([0, 0, 0], [1, -1, 1]), "radii"),
    (lambda: EllipsoidSurface.from_radii([0, 0, 0], [1, 1, 1], np.ones((3, 3))), "rotation"),
    (lambda: RectangleSurface([0, 0, 0], [1, 0, 0], [2, 0, 0]), "edge1, edge2"),
    (lambda: RectangleSurface([0, 0, 0], [0, 0, 0], [0, 1, 0]), "edge1"),
    (lambda: RectangleSurface([0, 0, 0], [1, 0, 0], [0, 1]), "edge2"),
    (lambda: RectangleSurface.from_matrix(np.eye(3)), "matrix"),
    (lambda: RectangleSurface.from_matrix(np.diag([1.0, 1.0, 1.0, 2.0])), "matrix"),
    (lambda: BoxSurface([0, 0, 0], [1, 0, 1]), "half_extents"),
    (lambda: BoxSurface([0, 0, 0], [1, 1, 1], rotation=2 * np.eye(3)), "rotation"),
    (lambda: BoxSurface.from_matrix(np.diag([1.0, 1.0, 0.0, 1.0])), "matrix"),
    (lambda: SphereCone([0, 0, 0], -1.0, [0, 0, 5]), "radius"),
    (lambda: SphereCone([0, 0, 0], 1.0, [0, 5]), "ref"),
    (lambda: SolidAngleFromArea(sphere(), [1.0, 2.0]), "ref"),
    (lambda: SolidAngleFromArea(object(), [1.0, 2.0, 3.0]), "surface"),
    (lambda: sphere().sample(np.zeros((4, 3))), "u"),
    (lambda: DiskSurface([0, 0, 0], [1, 0, 0], [2, 0, 0]), "axis1, axis2"),
    (lambda: DiskSurface([0, 0, 0], [0, 0, 0], [0, 1, 0]), "axis1"),
    (lambda: DiskSurface([0, 0, 0], [1, 0, 0], [0, 1]), "axis2"),
    (lambda: DiskSurface([0, 0, np.inf], [1, 0, 0], [0, 1, 0]), "center"),
    (lambda: DiskSurface([0, 0, 0], [1, 0, 0], [0, 1, 0], method="square"), "method"),
    (lambda: DiskSurface.from_matrix(np.diag([1.0, 1.0, 1.0, 2.0])), "matrix"),
])
def test_bad_input_raises_value_error(build, arg):
    with pytest.raises(ValueError, match=arg):
        build()


@pytest.mark.parametrize("flip_normals", [False, True])
def test_disk_from_matrix_follows_mitsuba(flip_normals):
    """Mitsuba 3's ``disk`` under to_world (one with det < 0): the same point for the same u
    (both use the concentric map), its normal M^-T e_z, area and pdf."""
    mi = pytest.importorskip("mitsuba")
    mi.set_variant("scalar_rgb")
    for M in (np.array([[1.0, 0.3, 0, 1], [0, -0.8, 0.2, 2], [0.1, 0, 1.5, 3], [0, 0, 0, 1]]),   # det < 0
              np.array([[0.5, 0.0, 0.2, -1], [0.1, 0.9, 0, 0], [0, 0.2, 1, 2], [0, 0, 0, 1]])):
        ref = mi.load_dict({"type": "disk", "to_world": mi.ScalarTransform4f(M), "flip_normals": flip_normals})
        dk = DiskSurface.from_matrix(M, flip_normals=flip_normals)
        u = as_generator(7).random((40, 2))
        ps = [ref.sample_position(0.0, mi.Point2f(*v)) for v in u]
        np.testing.assert_allclose(dk.sample(u), [np.array(p.p) for p in ps], rtol=0, atol=1e-5)
        np.testing.assert_allclose(dk.normal(dk.sample(u)), [np.array(p.n) for p in ps], rtol=0, atol=1e-6)
        assert dk.area == pytest.approx(ref.surface_area(), rel=1e-6)
        assert dk.pdf(dk.sample(u[:1]))[0] == pytest.approx(ps[0].pdf, rel=1e-6)


def test_float32_inputs_stay_float32_and_match_float64():
    """The renderer runs frames, hemisphere/GGX warps, sphere cones and MIS weights in
    float32 (as_float keeps float32, everything else is float64): same values to float32
    accuracy, including the small, far cone of veach_mis's smallest light."""
    from vrlab.distributions import GGX, CosineHemisphere, Frame
    from vrlab.estimators.mis import mis_weights
    g = as_generator(5)
    u64 = g.random((4000, 2)) * (1 - 2**-24)
    u32 = u64.astype(np.float32)
    n64 = g.normal(size=(4000, 3))
    n64 /= np.linalg.norm(n64, axis=-1, keepdims=True)
    n32 = n64.astype(np.float32)
    for d in (CosineHemisphere(), GGX(0.05)):
        w32, w64 = d.sample(u32), d.sample(u32.astype(float))
        assert w32.dtype == d.pdf(w32).dtype == np.float32
        np.testing.assert_allclose(w32[:, :2], w64[:, :2], atol=3e-5)
        # near the horizon z = sqrt(1 - x^2 - y^2): float32 resolves z^2 to some ulps of 1,
        # z itself only to ~1e-7 / z (5e-5 at z = 0.002, where one ulp more or less from
        # float32 sin/cos would decide a check of z at 3e-5); z^2 is well-conditioned
        np.testing.assert_allclose(w32[:, 2].astype(float) ** 2, w64[:, 2] ** 2, atol=2e-6)
        # the float32 pdf against the float64 one at the same directions
        np.testing.assert_allclose(d.pdf(w32), d.pdf(w32.astype(float)), rtol=2e-4, atol=1e-5)
    f32, f64 = Frame(n32), Frame(n32.astype(float))
    assert f32.to_world(n32).dtype == np.float32
    np.testing.assert_allclose(f32.to_local(n32), f64.to_local(n32.astype(float)), atol=1e-6)
    ref = (g.normal(size=(4000, 3)) * 5 + [0, 0, 12]).astype(np.float32)
    c32 = SphereCone(np.zeros((4000, 3), np.float32), np.full(4000, 0.033, np.float32), ref)
    c64 = SphereCone(np.zeros(3), 0.033, ref.astype(float))
    s32, s64 = c32.sample_point(u32), c64.sample_point(u32.astype(float))
    assert s32.w.dtype == s32.y.dtype == s32.pdf.dtype == np.float32
    np.testing.assert_allclose(s32.pdf, s64.pdf, rtol=1e-5)          # 1 / solid angle, stable
    np.testing.assert_allclose(s32.dist, s64.dist, rtol=1e-5)        # 12 away: 2e-6 relative at grazing
    np.testing.assert_allclose(s32.y, s64.y, atol=1e-4)              # on the sphere (r = 0.033)
    assert np.all(c64.pdf(s32.w.astype(float)) > 0)                  # inside the cone
    from vrlab._vec import side
    from vrlab.distributions.base import uniforms32
    u = uniforms32(np.array([0.0, 0.3, 1 - 1e-12]))              # rounds to 1 in plain float32
    assert u.dtype == np.float32 and u[0] == 0 and u[1] == np.float32(0.3) and u[2] < 1
    x = np.array([-2.0, -0.0, 0.0, 3.0], np.float32)
    assert side(x).dtype == np.float32 and side(x).tolist() == [-1, 1, 1, 1]
    q = g.random((4000, 2)) * 1e3
    w = mis_weights(q.astype(np.float32), "power")
    assert w.dtype == np.float32
    np.testing.assert_allclose(w, mis_weights(q, "power"), rtol=1e-5, atol=1e-7)
