"""Counted cost (issue 31, point 6): each render counts its rays, BSDF and emitter samples and
evaluations and light-BVH walks (vrlab.render.cost), in Estimate.extra["cost"] and --json;
--compare --equal-cost ranks strategies by relMSE x counted cost.

The closed forms come from what each strategy must do per pixel sample (derived here, not read
back from the counters): on OPEN_FLOOR every camera ray hits a diffuse floor and every ray
leaving it upwards reaches the constant environment, so each count is a multiple of the number
of samples N; on cornell_box the shaded camera hits are found from the camera rays' own hit
mask.  Each test's mutation (a counter that forgets shadow rays, one that double counts, units
summed wrongly) is shown to fail it."""
import json

import numpy as np
import pytest

from conftest import run_cli
from vrlab.render import load_scene, plan, render, render_gradient_domain
from vrlab.render.cost import COUNTERS, Cost, cost_weights, parse_cost_weights
from vrlab.render.direct import DirectLighting

W, H, SPP = 16, 12, 4
N = W * H * SPP

# a huge diffuse floor seen from above (the whole view), lit by a constant environment only
OPEN_FLOOR = f"""<scene version="3.0.0">
  <integrator type="direct"/>
  <sensor type="perspective">
    <float name="fov" value="40"/>
    <transform name="to_world"><lookat origin="0, 1, 0" target="0, 0, 0" up="0, 0, -1"/></transform>
    <film type="hdrfilm"><integer name="width" value="{W}"/><integer name="height" value="{H}"/>
      <rfilter type="box"/></film>
  </sensor>
  <shape type="rectangle">
    <transform name="to_world"><scale value="1000"/><rotate x="1" angle="-90"/></transform>
    <bsdf type="diffuse"><rgb name="reflectance" value="0.5"/></bsdf>
  </shape>
  <emitter type="constant"><rgb name="radiance" value="1"/></emitter>
</scene>"""


@pytest.fixture(scope="module")
def floor():
    return load_scene(OPEN_FLOOR)


def totals(est) -> dict:
    return est.extra["cost"]["totals"]


def expected(**per_sample) -> dict:
    """Totals with the given counts per sample (x N), every other counter 0."""
    return {k: int(round(per_sample.get(k, 0) * N)) for k in COUNTERS}


# per pixel sample on OPEN_FLOOR, derived from each strategy's technique(s):
#   light:  a camera ray, a light sample, a shadow ray to it, the BSDF evaluated there;
#   bsdf:   a camera ray, a BSDF sample, the closest-hit ray along it, which reaches the
#           environment: the light's radiance (and density) there;
#   mis-power (1 + 1): both, the BSDF density at the light sample being the BSDF evaluation and
#           the light's density at the BSDF sample the emitter evaluation (each counted once);
#   ris (M = 4): M light candidates with their unshadowed target (M BSDF evaluations), then the
#           chosen one evaluated again (a BSDF and an emitter evaluation) behind a shadow ray to
#           the environment's known direction.
FLOOR_COUNTS = {
    "light": dict(camera_rays=1, shadow_rays=1, bsdf_evals=1, emitter_samples=1),
    "bsdf": dict(camera_rays=1, closest_rays=1, bsdf_samples=1, emitter_evals=1),
    "mis-power": dict(camera_rays=1, closest_rays=1, shadow_rays=1, bsdf_samples=1, bsdf_evals=1,
                      emitter_samples=1, emitter_evals=1),
    "ris": dict(camera_rays=1, shadow_rays=1, bsdf_evals=4 + 1, emitter_samples=4, emitter_evals=1),
}


def floor_mismatches(floor, strategies=tuple(FLOOR_COUNTS)) -> dict:
    out = {}
    for s in strategies:
        got = totals(render(floor, SPP, s, rng=3, ris_candidates=4))
        want = expected(**FLOOR_COUNTS[s])
        if got != want:
            out[s] = (got, want)
    return out


def test_counts_on_the_open_floor_follow_the_closed_forms(floor):
    assert floor_mismatches(floor) == {}
    est = render(floor, SPP, "light", rng=3, emitter_samples=3)          # 3 light samples per camera ray
    assert totals(est) == expected(camera_rays=1, shadow_rays=3, bsdf_evals=3, emitter_samples=3)
    cost = est.extra["cost"]
    assert cost["samples"] == N and cost["per_sample"]["shadow_rays"] == 3.0
    assert cost["weighted_per_sample"] == pytest.approx(1 + 3 + 0.1 * (3 + 3))       # the default weights


def test_mutated_counters_fail_the_closed_forms(floor, monkeypatch):
    """A shadow ray not counted, a closest-hit ray counted twice, a BSDF evaluation counted at
    each use instead of once per point: each breaks the closed forms."""
    from vrlab.render.shading import ShadingIntegrand

    real_unblocked, real_trace = DirectLighting.unblocked, DirectLighting.trace
    with monkeypatch.context() as m:
        m.setattr(DirectLighting, "unblocked", lambda self, *a, cost=None: real_unblocked(self, *a))
        assert set(floor_mismatches(floor, ("light", "mis-power"))) == {"light", "mis-power"}
    with monkeypatch.context() as m:
        def twice(self, *a, cost=None):
            if cost is not None:
                cost.closest_rays += len(a[0])
            return real_trace(self, *a, cost=cost)
        m.setattr(DirectLighting, "trace", twice)
        assert set(floor_mismatches(floor, ("bsdf", "light"))) == {"bsdf"}
    with monkeypatch.context() as m:
        def every_use(self, r):
            self.cost.bsdf_evals += len(r.j)
        m.setattr(ShadingIntegrand, "count_bsdf", every_use)
        assert set(floor_mismatches(floor, ("mis-power", "light"))) == {"mis-power"}


def _shaded_camera_hits(integ, pixels, u) -> int:
    """Camera rays that hit a surface with a non-black BSDF, from the rays themselves."""
    lit = integ.lighting
    o, d = lit.camera.pixel_rays(pixels[:, None, :], u[..., :integ.camera_dims], np.float32)
    geometry = lit.blocker_geometry if lit.hide_emitters else lit.geometry
    shape = geometry.intersect(o.reshape(-1, 3), d.reshape(-1, 3)).shape
    return int(np.count_nonzero(lit.shaded[np.maximum(shape, 0)] & (shape >= 0)))


@pytest.mark.parametrize("n_l", [1, 2])
def test_light_sampling_traces_one_shadow_ray_per_light_sample_at_each_shaded_hit(n_l):
    """cornell_box, light sampling with n_l samples per camera ray: n_l shadow rays, light
    samples and BSDF evaluations per camera ray that hits a non-black surface (not the light,
    not the background), nothing else but the camera rays."""
    p = plan("cornell_box", 2, "light", width=20, height=15, emitter_samples=n_l)
    integ = p.integrand
    rng = np.random.default_rng(1)
    pixels = np.stack(np.divmod(np.arange(300), 20), -1)
    u = rng.random((300, 2, integ.dim))
    cost = Cost()
    integ.outputs(pixels, u, cost)
    hit = _shaded_camera_hits(integ, pixels, u)
    assert 0 < hit < 600                                     # some rays see the light or nothing
    assert cost.totals() == {**dict.fromkeys(COUNTERS, 0), "camera_rays": 600, "shadow_rays": n_l * hit,
                             "bsdf_evals": n_l * hit, "emitter_samples": n_l * hit}
    # MIS (1 + 1): a BSDF sample and its closest-hit ray too, and the light's density where it
    # reaches a light (at most one per BSDF sample)
    pm = plan("cornell_box", 2, "mis-power", width=20, height=15).integrand
    um = rng.random((300, 2, pm.dim))
    cm = Cost()
    pm.outputs(pixels, um, cm)
    hit = _shaded_camera_hits(pm, pixels, um)
    assert (cm.shadow_rays, cm.closest_rays, cm.bsdf_samples, cm.bsdf_evals, cm.emitter_samples) == (hit,) * 5
    assert 0 < cm.emitter_evals < cm.closest_rays and cm.light_walks == 0


def test_light_bvh_walks_once_per_light_sample_and_per_pmf_of_a_reached_light():
    light = render("cornell_box", 2, "light", width=20, height=15, rng=2, light_selection="bvh")
    t = totals(light)
    assert t["light_walks"] == t["emitter_samples"] > 0
    mis = totals(render("cornell_box", 2, "mis-power", width=20, height=15, rng=2, light_selection="bvh"))
    assert mis["light_walks"] == mis["emitter_samples"] + mis["emitter_evals"] and mis["emitter_evals"] > 0
    uniform = totals(render("cornell_box", 2, "mis-power", width=20, height=15, rng=2))
    assert uniform["light_walks"] == 0                      # a table lookup, not a walk


def test_restir_counts_its_reconnections(floor):
    """ReSTIR (M candidates, k neighbours, pairwise MIS, one pass): M light samples and targets per
    sample; then f (a shadow ray, a BSDF and an emitter evaluation) at 1 (visibility reuse) +
    (k + 1) (each contributor at the receiving pixel) + k (the canonical sample read at each
    neighbour, the pairwise weights) reconnections."""
    from vrlab.estimators import ReSTIR

    m, k = 3, 4
    est = render(floor, SPP, ReSTIR(candidates=m, neighbours=k, radius=2, mis="pairwise"), rng=1)
    f = 1 + (k + 1) + k
    got = totals(est)
    # the light's radiance is evaluated where a reconnection has a light: not from a pixel whose
    # candidates all missed (the environment sampled below the floor's horizon: an empty reservoir)
    assert 0.5 * f * N < got.pop("emitter_evals") < f * N
    assert got == {name: v for name, v in expected(camera_rays=1, shadow_rays=f, bsdf_evals=m + f,
                                                   emitter_samples=m).items() if name != "emitter_evals"}


def test_gradient_domain_counts_three_pixel_evaluations_per_sample(floor):
    gd = render_gradient_domain(floor, SPP, "light", rng=0)
    assert gd.primal.extra["cost"] == gd.dx.extra["cost"]
    assert gd.primal.extra["cost"]["totals"] == expected(camera_rays=3, shadow_rays=3, bsdf_evals=3, emitter_samples=3)


def test_counts_are_the_same_for_any_worker_count(monkeypatch):
    """cornell_box at 48 x 48 (3 tiles) in 2 batches: workers 1 and 2 count the same; summing one
    unit's counts twice (the mutation) does not."""
    import vrlab.render.film as film

    kw = dict(width=48, height=48, rng=4, spp_batch=1)
    one = render("cornell_box", 2, "mis-power", workers=1, **kw).extra["cost"]
    two = render("cornell_box", 2, "mis-power", workers=2, **kw).extra["cost"]
    assert one == two and one["samples"] == 48 * 48 * 2
    real = film.Cost.add
    monkeypatch.setattr(film.Cost, "add", lambda self, other: real(real(self, other), other))
    assert render("cornell_box", 2, "mis-power", workers=1, **kw).extra["cost"] != one


def test_cost_weights_check_their_input():
    assert cost_weights(None)["shadow_rays"] == 1.0 and cost_weights(None)["bsdf_evals"] == 0.1
    w = cost_weights({"rays": 2, "shadow_rays": 5})          # the group first, then the name
    assert (w["camera_rays"], w["closest_rays"], w["shadow_rays"]) == (2, 2, 5)
    for bad, err in (({"rays": -1}, ValueError), ({"ray": 1}, ValueError), ({"rays": "1"}, TypeError),
                     ({"rays": float("nan")}, ValueError), (dict.fromkeys(COUNTERS, 0), ValueError),
                     ([1], TypeError)):
        with pytest.raises(err, match="^cost_weights"):
            cost_weights(bad)
    assert parse_cost_weights("rays=1, evals=0.5")["emitter_evals"] == 0.5
    for text in ("rays", "rays=1,rays=2", "=1", "rays=x", "rays=inf", ""):
        with pytest.raises(ValueError, match="^--cost-weights"):
            parse_cost_weights(text)


def test_render_json_holds_the_cost(capsys, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)                              # --gradient-domain without -o writes nothing
    scene = tmp_path / "floor.xml"
    scene.write_text(OPEN_FLOOR)
    code, out, err = run_cli(capsys, ["render", str(scene), "--spp", str(SPP), "--strategy", "light", "--json"])
    assert code == 0, err
    cost = json.loads(out)["cost"]
    assert cost["totals"] == expected(**FLOOR_COUNTS["light"]) and cost["samples"] == N
    code, out, err = run_cli(capsys, ["render", str(scene), "--spp", str(SPP), "--strategy", "light", "--json",
                                      "--gradient-domain"])
    assert code == 0, err
    cost = json.loads(out)["cost"]                           # three pixel evaluations per sample
    assert cost["totals"] == {k: 3 * v for k, v in expected(**FLOOR_COUNTS["light"]).items()}
    code, out, err = run_cli(capsys, ["render", str(scene), "--spp", str(SPP), "--strategy", "light"])
    assert code == 0 and "cost_per_sample=2.2" in out, out          # the text line: the weighted cost


def test_equal_cost_ranks_by_rel_mse_times_weighted_counts(capsys, tmp_path):
    """light and bsdf on the open floor cost the same with the default weights (per sample: 2 rays
    + 2 samples or evaluations at 0.1 each = 2.2); without shadow rays' weight light costs 1.2:
    its ratio to bsdf falls by 2.2 / 1.2 and the products are relMSE x spp x that, by hand."""
    scene = tmp_path / "floor.xml"
    scene.write_text(OPEN_FLOOR)
    argv = ["render", str(scene), "--spp", str(SPP), "--compare", "bsdf,light", "--reference-spp", "16",
            "--equal-cost", "--json"]
    code, out, err = run_cli(capsys, argv)
    assert code == 0, err
    a = json.loads(out)
    code, out, err = run_cli(capsys, argv + ["--cost-weights", "shadow_rays=0"])
    assert code == 0, err
    b = json.loads(out)
    assert a["rel_mse"] == b["rel_mse"] and a["counted_cost"]["light"]["totals"] == expected(**FLOOR_COUNTS["light"])
    for res, c_light, c_bsdf in ((a, 2.2, 2.2), (b, 1.2, 2.2)):
        table = res["equal_cost"]
        for s, c in (("light", c_light), ("bsdf", c_bsdf)):
            assert table["rel_mse_x_cost"][s] == pytest.approx(res["rel_mse"][s] * SPP * c)
            assert table["rel_mse_x_time"][s] == pytest.approx(res["rel_mse"][s] * res["seconds"][s])
    ratio = [r["equal_cost"]["rel_mse_x_cost"]["light"] / r["equal_cost"]["rel_mse_x_cost"]["bsdf"] for r in (a, b)]
    assert ratio[0] / ratio[1] == pytest.approx(2.2 / 1.2)
    assert b["equal_cost"]["weights"]["shadow_rays"] == 0 and a["equal_cost"]["weights"]["shadow_rays"] == 1
    # the text output ranks them too
    code, out, _ = run_cli(capsys, argv[:-1])
    assert code == 0 and "ranking at equal counted cost:" in out and "relMSE x time" in out


@pytest.mark.parametrize("extra,flag", [
    (["--equal-cost"], "--equal-cost"), (["--cost-weights", "rays=1"], "--cost-weights"),
    (["--compare", "bsdf", "--cost-weights", "rays=1"], "--cost-weights"),
    (["--compare", "bsdf", "--equal-cost", "--cost-weights", "rays=-1"], "--cost-weights"),
    (["--compare", "bsdf", "--equal-cost", "--cost-weights", "ray=1"], "--cost-weights"),
    (["--compare", "bsdf", "--equal-cost", "--cost-weights", "rays=lots"], "--cost-weights"),
    (["--compare", "bsdf", "--equal-cost", "--cost-weights", "rays"], "--cost-weights"),
    (["--gradient-domain", "--equal-cost"], "--equal-cost"),
], ids=lambda v: " ".join(v) if isinstance(v, list) else v)
def test_bad_cost_flags_are_one_line_usage_errors(extra, flag, capsys, monkeypatch):
    monkeypatch.setattr("vrlab.render.compare.compare", lambda *a, **k: pytest.fail("compare started"))
    code, out, err = run_cli(capsys, ["render", "furnace", "--width", "8", "--height", "6", *extra])
    assert code == 2 and out == ""
    lines = err.splitlines()
    assert len(lines) == 1 and lines[0].startswith("vrlab render: error: ") and flag in lines[0], err


def test_compare_refuses_bad_weights_before_rendering(monkeypatch):
    from vrlab.render.compare import compare

    monkeypatch.setattr("vrlab.render.compare.render", lambda *a, **k: pytest.fail("rendered"))
    with pytest.raises(ValueError, match="^cost_weights"):
        compare("furnace", ["bsdf"], 2, cost_weights={"rays": -1})
