"""EnvironmentMap (Mitsuba 3's envmap): closed-form conventions, chi-square of sample vs pdf,
normalisation, and agreement with Mitsuba 3.9 scalar_rgb (eval, pdf pointwise, its samples)."""
import numpy as np
import pytest

from vrlab import distributions as D
from vrlab.distributions.envmap import EnvironmentMap, latlong_direction, latlong_uv
from vrlab.testing import SphereChart, assert_gof, chi2_gof, integrate, pooled_chi2

PI = np.pi
RNG = np.random.default_rng(20261201)
IMAGE = RNG.uniform(0.1, 2.0, (6, 10, 3))                   # random map, 10 x 6 pixels
SPOT = np.full((16, 32, 3), 0.05)
SPOT[5:7, 20:22] = [400.0, 300.0, 200.0]                   # a bright 2 x 2 pixel sun
MIS = RNG.lognormal(0.0, 1.0, (8, 12, 3))                  # for mis_compensation (dim half is zero)


def rotation(axis, angle):
    """Rodrigues' rotation matrix about a unit ``axis`` by ``angle`` (radians)."""
    a = np.asarray(axis, float) / np.linalg.norm(axis)
    k = np.array([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])
    return np.eye(3) + np.sin(angle) * k + (1 - np.cos(angle)) * (k @ k)


TILT = rotation([1.0, 2.0, 3.0], 0.7)

CASES = {
    "random-cdf": EnvironmentMap(IMAGE, table="cdf"),
    "random-alias-rotated": EnvironmentMap(IMAGE, to_world=TILT, table="alias"),
    "spot-cdf-rotated": EnvironmentMap(SPOT, to_world=TILT, table="cdf"),
    "spot-alias": EnvironmentMap(SPOT, scale=3.0),
    "mis-compensation-alias": EnvironmentMap(MIS, mis_compensation=True),
}


# -- conventions (closed forms) ------------------------------------------------------------------

def test_latlong_axes():
    # u = 0 looks along -z, u = 1/4 along +x, 1/2 along +z, 3/4 along -x; v = 0 is +y
    d = np.array([[0, 0, -1], [1, 0, 0], [0, 0, 1], [-1, 0, 0], [0, 1, 0], [0, -1, 0]], float)
    uv = latlong_uv(d)
    np.testing.assert_allclose(uv[:4], [[0, 0.5], [0.25, 0.5], [0.5, 0.5], [0.75, 0.5]], atol=1e-15)
    np.testing.assert_allclose(uv[4:, 1], [0.0, 1.0], atol=1e-15)
    np.testing.assert_allclose(latlong_direction(uv[:4]), d[:4], atol=1e-15)
    theta, phi = 0.3, 1.1
    np.testing.assert_allclose(latlong_direction([phi / (2 * PI), theta / PI]),
                               [np.sin(phi) * np.sin(theta), np.cos(theta), -np.cos(phi) * np.sin(theta)])


def test_uv_and_direction_apply_to_world():
    env = EnvironmentMap(IMAGE, to_world=np.block([[TILT, np.ones((3, 1))], [np.zeros((1, 3)), 1]]))
    uv = RNG.random((50, 2))
    w = env.direction(uv)
    np.testing.assert_allclose(w, latlong_direction(uv) @ TILT.T, atol=1e-14)   # translation ignored
    np.testing.assert_allclose(env.uv(w), uv, atol=1e-12)
    np.testing.assert_allclose(env.uv(w.astype(np.float32) * 3.0), uv, atol=1e-6)  # any length, float32


def test_eval_at_texel_centres_and_across_the_seam():
    h, w = IMAGE.shape[:2]
    env = EnvironmentMap(IMAGE, scale=2.5)
    j, i = np.meshgrid(np.arange(h), np.arange(w), indexing="ij")
    centres = np.stack([(i + 0.5) / w, j / (h - 1)], -1)             # column i at (i + 1/2) / W, row j at j / (H - 1)
    np.testing.assert_allclose(env.eval(env.direction(centres[1:-1])), 2.5 * IMAGE[1:-1], rtol=1e-12)
    # the first and last rows are the poles (one direction each): approach them along column i
    near = centres[[0, -1]] + [0.0, 1e-9] * np.array([1, -1])[:, None, None]
    np.testing.assert_allclose(env.eval(env.direction(near)), 2.5 * IMAGE[[0, -1]], rtol=1e-7)
    # u = 0 lies halfway between the last column's centre and the first's; u = 1/(4W) a
    # quarter texel past the seam, v halfway between rows 1 and 2
    seam = env.eval(env.direction([[0.0, 2 / (h - 1)], [0.25 / w, 1.5 / (h - 1)]]))
    np.testing.assert_allclose(seam[0], 2.5 * (IMAGE[2, 0] + IMAGE[2, -1]) / 2, rtol=1e-12)
    rows = 0.5 * (IMAGE[1] + IMAGE[2])
    np.testing.assert_allclose(seam[1], 2.5 * (0.25 * rows[-1] + 0.75 * rows[0]), rtol=1e-12)


def _vertex_weights(image):
    """Mitsuba's q[j, i] = luminance x sin(pi j / (H - 1)), written out (column W = column 0)."""
    h = image.shape[0]
    q = (image @ [0.212671, 0.715160, 0.072169]) * np.sin(PI * np.arange(h) / (h - 1))[:, None]
    q[-1] = 0.0                                          # sin(pi) is 0, not 1e-16
    return np.concatenate([q, q[:, :1]], 1)


def test_pdf_is_bilinear_over_jacobian():
    # p(w) = p_uv / (2 pi^2 sin theta), p_uv the bilinear interpolant of q over the cell
    # (u_w, v) of the direction, over the mean cell mass (mean of each cell's 4 corners)
    env = EnvironmentMap(IMAGE)
    h, w = IMAGE.shape[:2]
    q = _vertex_weights(IMAGE)
    c = (q[:-1, :-1] + q[1:, :-1] + q[:-1, 1:] + q[1:, 1:]) / 4
    iy, ix, s, t = 3, 9, 0.3, 0.6                        # the cell that wraps across the seam
    uv = np.array([(ix + s) / w + 0.5 / w, (iy + t) / (h - 1)])
    f = (1 - t) * ((1 - s) * q[iy, ix] + s * q[iy, 0]) + t * ((1 - s) * q[iy + 1, ix] + s * q[iy + 1, 0])
    expected = f / c.mean() / (2 * PI**2 * np.sin(PI * uv[1]))
    assert env.pdf(env.direction(uv)) == pytest.approx(expected, rel=1e-12)


def test_pdf_is_finite_at_the_poles():
    # q is 0 on the pole rows, so p_uv ~ t q[1] (or (1 - t) q[H-2]) and sin theta ~ pi t / (H - 1):
    # p -> lerp(q[1]) (H - 1) / (pi mean(c) 2 pi^2) along a meridian
    env = EnvironmentMap(IMAGE)
    h, w = IMAGE.shape[:2]
    q = _vertex_weights(IMAGE)
    c = (q[:-1, :-1] + q[1:, :-1] + q[:-1, 1:] + q[1:, 1:]) / 4
    s, eps = 0.25, 1e-7
    uv = np.array([[(2 + s + 0.5) / w, eps], [(5 + s + 0.5) / w, 1 - eps]])
    rows = np.array([(1 - s) * q[1, 2] + s * q[1, 3], (1 - s) * q[h - 2, 5] + s * q[h - 2, 6]])
    np.testing.assert_allclose(env.pdf(env.direction(uv)), rows * (h - 1) / (PI * c.mean() * 2 * PI**2), rtol=1e-6)


# -- sampling ------------------------------------------------------------------------------------

@pytest.mark.parametrize("name", sorted(CASES))
def test_chi_square_on_the_sphere(name):
    env = CASES[name]
    res = chi2_gof(env, SphereChart(), (20, 30), n=100_000, rng=7, sub=4, name=name)
    assert_gof(res, alpha=0.01, m=len(CASES))


@pytest.mark.parametrize("name", sorted(CASES))
def test_pdf_integrates_to_one(name):
    assert integrate(CASES[name].pdf, SphereChart(), (96, 96), quad=8) == pytest.approx(1.0, abs=2e-3)


@pytest.mark.parametrize("name", sorted(CASES))
def test_sample_pdf_matches_pdf(name):
    env = CASES[name]
    u = RNG.uniform(1e-6, 1 - 1e-6, (2000, 2))
    w, p = env.sample_pdf(u)
    np.testing.assert_allclose(np.linalg.norm(w, axis=-1), 1.0, atol=1e-14)
    np.testing.assert_allclose(env.sample(u), w, rtol=0, atol=0)
    np.testing.assert_allclose(env.pdf(w), p, rtol=1e-9)
    assert np.all(p > 0)


def test_mis_compensation_zeroes_dim_cells():
    env = CASES["mis-compensation-alias"]
    lum = MIS @ [0.212671, 0.715160, 0.072169]
    assert env.offset == pytest.approx(lum.mean())
    off = lum <= lum.mean()                              # no weight: at most the mean ...
    off[[0, -1]] = True                                  # ... or on a pole row (sin theta = 0)
    zero = off[:-1] & off[1:] & np.roll(off[:-1], -1, 1) & np.roll(off[1:], -1, 1)
    assert zero.any() and not zero.all()
    np.testing.assert_array_equal(env.weights == 0, zero)
    assert np.all(env.pdf(env.direction(np.stack([(np.argwhere(zero)[:, 1] + 1.0) / MIS.shape[1],
                                                   (np.argwhere(zero)[:, 0] + 0.5) / 7], -1))) == 0)
    assert EnvironmentMap(np.ones((4, 4, 3)), mis_compensation=True).offset == 0.0   # constant map: off


def test_invert_only_with_cdf_table():
    env = EnvironmentMap(IMAGE, to_world=TILT, table="cdf")
    u = RNG.uniform(1e-6, 1 - 1e-6, (3000, 2))
    np.testing.assert_allclose(env.invert(env.sample(u)), u, atol=1e-9)
    assert not hasattr(EnvironmentMap(IMAGE, table="alias"), "invert")


@pytest.mark.parametrize("make, exc, name", [
    (lambda: EnvironmentMap(np.ones((6, 10))), ValueError, "image"),
    (lambda: EnvironmentMap(np.ones((2, 10, 3))), ValueError, "image"),
    (lambda: EnvironmentMap("sky.exr"), TypeError, "image"),
    (lambda: EnvironmentMap(-IMAGE), ValueError, "image"),
    (lambda: EnvironmentMap(np.where(IMAGE > 1.9, np.nan, IMAGE)), ValueError, "image"),
    (lambda: EnvironmentMap(np.zeros((6, 10, 3))), ValueError, "image"),
    (lambda: EnvironmentMap(IMAGE, to_world=2 * np.eye(3)), ValueError, "to_world"),
    (lambda: EnvironmentMap(IMAGE, to_world=np.eye(2)), ValueError, "to_world"),
    (lambda: EnvironmentMap(IMAGE, to_world=np.ones((4, 4))), ValueError, "to_world"),
    (lambda: EnvironmentMap(IMAGE, scale=-1.0), ValueError, "scale"),
    (lambda: EnvironmentMap(IMAGE, scale="2"), TypeError, "scale"),
    (lambda: EnvironmentMap(IMAGE, mis_compensation="yes"), TypeError, "mis_compensation"),
    (lambda: EnvironmentMap(IMAGE, table="hierarchical"), ValueError, "table"),
    (lambda: EnvironmentMap(IMAGE).sample(np.zeros((4, 3))), ValueError, "u"),
    (lambda: EnvironmentMap(IMAGE).pdf(np.zeros((4, 2))), ValueError, "w"),
])
def test_bad_input_names_the_argument(make, exc, name, raises_naming):
    with raises_naming(exc, name):
        make()


def test_constant_emitter_is_uniform_sphere(mi):
    em = mi.load_dict({"type": "constant", "radiance": {"type": "rgb", "value": [0.5, 1.0, 2.0]}})
    u = RNG.random((50, 2))
    got = [em.sample_direction(mi.Interaction3f(), mi.Point2f(*x)) for x in u]
    d = np.array([np.array(ds.d) for ds, _ in got])
    np.testing.assert_allclose(d, D.UniformSphere().sample(u[:, ::-1]), atol=1e-6)   # z = 1 - 2 u_y
    np.testing.assert_allclose([ds.pdf for ds, _ in got], 1 / (4 * PI), rtol=1e-6)


# -- agreement with Mitsuba 3 (scalar_rgb) ----------------------------------------------------------

@pytest.fixture(scope="module")
def mi():
    mitsuba = pytest.importorskip("mitsuba")
    mitsuba.set_variant("scalar_rgb")
    return mitsuba


@pytest.fixture(scope="module")
def maps(tmp_path_factory, mi):
    """Our maps and Mitsuba's emitters for an EXR (rotated, scaled) and an 8-bit sRGB PNG,
    each without and with mis_compensation; our images read back through vrlab's reader."""
    from PIL import Image

    from vrlab.render.image import read_bitmap, save_image, srgb_decode
    folder = tmp_path_factory.mktemp("envmap")
    rng = np.random.default_rng(5)
    exr, png = folder / "sky.exr", folder / "sky.png"
    save_image(exr, rng.lognormal(0.0, 0.7, (9, 16, 3)).astype(np.float32))
    Image.fromarray(rng.integers(0, 256, (7, 12, 3), dtype=np.uint8)).save(png)
    axis = np.array([1.0, -2.0, 0.5]) / np.linalg.norm([1.0, -2.0, 0.5])
    to_world = mi.ScalarTransform4f().rotate(axis.tolist(), 50.0)
    out = {}
    for path, kw in ((exr, {"scale": 1.7, "to_world": to_world}), (png, {})):
        bitmap = read_bitmap(path)
        rgb = srgb_decode(bitmap.data) if bitmap.srgb else bitmap.data
        ours = dict(kw, to_world=np.array(to_world.matrix, float)) if kw else {}
        for mis in (False, True):
            theirs = mi.load_dict({"type": "envmap", "filename": str(path), "mis_compensation": mis, **kw})
            out[f"{path.suffix[1:]}-mis" if mis else path.suffix[1:]] = (
                EnvironmentMap(rgb, mis_compensation=mis, **ours), theirs)
    return out


MAPS = ["exr", "exr-mis", "png", "png-mis"]


def _unit32(n, seed):
    """Random unit directions, rounded to float32 (Mitsuba's input precision: both sides see
    the same direction)."""
    w = np.random.default_rng(seed).normal(size=(n, 3))
    return (w / np.linalg.norm(w, axis=-1, keepdims=True)).astype(np.float32).astype(float)


@pytest.mark.parametrize("name", MAPS)
def test_eval_matches_mitsuba(maps, mi, name):
    env, em = maps[name]
    w = _unit32(400, 1)
    theirs = []
    for d in w:
        si = mi.SurfaceInteraction3f()
        si.wi = mi.Vector3f(*(-d))                     # eval looks up -si.wi, the direction towards the map
        theirs.append(np.array(em.eval(si)))
    theirs = np.array(theirs)
    np.testing.assert_allclose(env.eval(w), theirs, rtol=1e-4, atol=1e-6 * theirs.max())


def _mitsuba_pdf(mi, em, w):
    it, out = mi.Interaction3f(), []
    for d in w:
        ds = mi.DirectionSample3f()
        ds.d = mi.Vector3f(*d)
        out.append(em.pdf_direction(it, ds))
    return np.array(out)


@pytest.mark.parametrize("name", MAPS)
def test_pdf_matches_mitsuba_pointwise(maps, mi, name):
    """Our pdf is Mitsuba's pdf_direction at every direction (bilinear inside the cells, not
    only the same cell masses): random directions, 3 x 3 points in every cell and directions
    near both poles.  Mitsuba takes theta = acos(d_y) in float32 of the float32 local direction
    (rounded, of length 1 +- 6e-8, rotated in float32): an error of ~1e-7 in d_y shifts theta by
    a relative 1e-7 / sin^2 theta, so directions with sin theta < 0.1 (where that passes 1e-5,
    the float32 rounding of the poles) are left out.  The absolute floor
    covers Mitsuba's float32 lookups where the density nears 0 (its last row's weights are
    float32 sin(pi) = -9e-8, so it even returns -3e-7 there)."""
    env, em = maps[name]
    nx, ny = env.width, env.height - 1
    g = np.array([0.1, 0.5, 0.85])
    ix, iy, gx, gy = np.meshgrid(np.arange(nx), np.arange(ny), g, g, indexing="ij")
    grid = np.stack([(ix + gx + 0.5) / nx, (iy + gy) / ny], -1).reshape(-1, 2)
    rng = np.random.default_rng(3)
    theta = np.geomspace(0.1, 0.4, 100)
    poles = np.stack([rng.random(200), np.concatenate([theta, PI - theta]) / PI], -1)
    w = np.concatenate([_unit32(1000, 4), env.direction(np.concatenate([grid, poles]))])
    w = w.astype(np.float32).astype(float)
    w = w[np.sin(PI * env.uv(w)[:, 1]) >= 0.1]
    theirs, ours = _mitsuba_pdf(mi, em, w), env.pdf(w)
    assert (theirs > 0).mean() > 0.4
    np.testing.assert_allclose(ours, theirs, rtol=1e-4, atol=1e-6 * theirs.max())


@pytest.mark.parametrize("name", MAPS)
def test_mitsuba_samples_follow_our_pdf(maps, mi, name):
    """Mitsuba's own sample_direction: its weight x pdf is our radiance at its direction, and
    its samples fall in the quarters of our cells (2 x 2 bins per cell in (u_w, v)) with our
    probabilities (chi-square): the integral of a bilinear density over a bin inside one cell
    is the bin's area times the mean of its 4 corner values, exactly.  A piecewise-constant
    density with the same cell masses fails it."""
    env, em = maps[name]
    n = 20_000
    u = np.random.default_rng(2).random((n, 2))
    it = mi.Interaction3f()
    d, pdf, weight = np.empty((n, 3)), np.empty(n), np.empty((n, 3))
    for k in range(n):
        ds, wt = em.sample_direction(it, mi.Point2f(u[k, 0], u[k, 1]))
        d[k], pdf[k], weight[k] = ds.d, ds.pdf, wt
    keep = slice(0, 400)
    np.testing.assert_allclose(weight[keep] * pdf[keep, None], env.eval(d[keep]), rtol=1e-4,
                               atol=1e-6 * weight[keep].max())
    uv = env.uv(d)
    uw = np.mod(uv[:, 0] - 0.5 / env.width, 1.0)          # cells start half a texel after u = 0
    nb = np.array([2 * env.width, 2 * (env.height - 1)])  # bins along u_w, v
    bins = np.minimum((np.stack([uw, uv[:, 1]], -1) * nb).astype(int), nb - 1)
    counts = np.bincount(bins[:, 1] * nb[0] + bins[:, 0], minlength=nb.prod())
    by, bx = np.meshgrid(np.arange(nb[1]), np.arange(nb[0]), indexing="ij")
    corners = [np.stack([(bx + a) / nb[0], (by + b) / nb[1]], -1) for a in (0, 1) for b in (0, 1)]
    mass = sum(env.warp.pdf(c) for c in corners) / 4 / nb.prod()
    assert mass.sum() == pytest.approx(1.0, rel=1e-12)
    res = pooled_chi2(counts, n * mass.ravel(), name=f"mitsuba {name}")
    assert_gof(res, alpha=0.01, m=len(MAPS))


class _SinDropped:
    """Mutation: the luminance map's samples, with the pdf of the (u, v) square taken as a
    density on the sphere without the 1 / (2 pi^2 sin theta) Jacobian's sin theta."""

    dim, dim_u = 3, 2

    def __init__(self, env):
        self.env = env

    def sample(self, u):
        return self.env.sample(u)

    def pdf(self, w):
        w = np.asarray(w, float)
        return self.env.pdf(w) * np.sqrt(np.clip(1.0 - w[..., 1] ** 2, 0.0, 1.0))   # latitude from +y


def test_a_dropped_sin_theta_fails():
    wrong = _SinDropped(CASES["random-cdf"])
    with pytest.raises(AssertionError):
        assert_gof(chi2_gof(wrong, SphereChart(), (20, 30), n=100_000, rng=7, sub=4, name="sin dropped"), alpha=0.01)
    assert abs(integrate(wrong.pdf, SphereChart(), (96, 96), quad=8) - 1.0) > 0.05
