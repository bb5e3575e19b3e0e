"""vrlab.render.spectra against Mitsuba 3 itself (``scalar_rgb``; ``scalar_spectral`` for the
black body, which the RGB variants cannot evaluate): the sRGB value Mitsuba stores for a
``<spectrum>`` (read back with ``mi.traverse``), its named IORs and conductors, its CIE tables."""
import os
import re
import warnings

import numpy as np
import pytest

from vrlab.render import spectra as S

mi = pytest.importorskip("mitsuba")

REL, ABS = 1e-4, 1e-6


@pytest.fixture(autouse=True, scope="module")
def rgb_variant():
    mi.set_variant("scalar_rgb")


def close(ours, theirs, rel=REL, abs_=ABS):
    ours, theirs = np.asarray(ours, float), np.asarray(theirs, float)
    return np.all(np.abs(ours - theirs) <= np.maximum(rel * np.abs(theirs), abs_)), np.abs(ours - theirs).max()


def mitsuba_rgb(text, kind):
    """What scalar_rgb stores for <spectrum value=text> used as a reflectance, an emitted
    radiance or an unbounded quantity (a conductor's eta)."""
    spec = f'<spectrum name="{{}}" value="{text}"/>'
    if kind == "reflectance":
        obj, key = f'<bsdf version="3.0.0" type="diffuse">{spec.format("reflectance")}</bsdf>', "reflectance.value"
    elif kind == "emission":
        obj, key = f'<emitter version="3.0.0" type="area">{spec.format("radiance")}</emitter>', "radiance.value"
    else:
        obj, key = (f'<bsdf version="3.0.0" type="conductor">{spec.format("eta")}<float name="k" value="1"/></bsdf>',
                    "eta.value")
    value = mi.traverse(mi.load_string(obj))[key]
    return np.broadcast_to(np.array(value, dtype=float), 3)


SPECTRA = {
    "flat": "360:1, 830:1",
    "flat-bright": "400:1.5, 700:1.5",                 # > 1: a reflectance is clipped to 1
    "ramp": "400:0.1, 500:0.8, 600:0.3, 700:0.5",
    "narrow": "500:1, 510:1",                            # out of gamut: negative red clamped
    "partly-outside": "300:0.2, 450:0.9, 900:0.4",
    "mostly-outside": "200:5, 300:5, 350:1, 361:2",
    "red-edge": "380:0, 780:1",
    "uniform": "0.5",
}


@pytest.mark.parametrize("kind", S.KINDS)
@pytest.mark.parametrize("name", SPECTRA)
def test_spectrum_rgb_matches_mitsuba(name, kind):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", S.GamutWarning)
        ours = S.spectrum_property_rgb(SPECTRA[name], kind=kind)
    ok, err = close(ours, mitsuba_rgb(SPECTRA[name], kind))
    assert ok, (name, kind, ours, err)


def test_rules_are_far_apart():
    """The three rules differ by far more than the tolerance, so mixing them up (say, dropping
    the D65 weight of a reflectance) cannot pass test_spectrum_rgb_matches_mitsuba."""
    text = SPECTRA["ramp"]
    for kind in S.KINDS:
        theirs = mitsuba_rgb(text, kind)
        for other in set(S.KINDS) - {kind}:
            if {kind, other} != {"reflectance", "unbounded"}:      # these differ only in clamping
                assert not close(S.spectrum_property_rgb(text, kind=other), theirs, 100 * REL)[0]


def test_clamping_warns_like_mitsuba():
    with pytest.warns(S.GamutWarning, match="out-of-gamut"):
        rgb = S.spectrum_to_rgb([500, 510], [1, 1], kind="reflectance")
    assert rgb[0] == 0
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert np.all(S.spectrum_to_rgb([400, 700], [1.5, 1.5], kind="emission") > 1)   # only < 0 clamps
        np.testing.assert_array_equal(S.spectrum_to_rgb([500, 510], [1, 1], kind="emission", warn=False)[0], 0)


def test_cie_tables_match_mitsuba():
    lam = np.r_[360 + 5 * np.arange(95), np.linspace(352.3, 838.1, 41)]
    ours_xyz, ours_d65 = S.cie1931_xyz(lam), S.cie_d65(lam)
    theirs_xyz = np.array([list(mi.cie1931_xyz(float(w))) for w in lam])
    theirs_d65 = np.array([mi.cie_d65(float(w)) for w in lam])
    assert close(ours_xyz, theirs_xyz, REL, 1e-9)[0]        # Mitsuba interpolates in float32
    assert close(ours_d65, theirs_d65, REL, 1e-9)[0]
    assert np.all(ours_xyz[(lam < 360) | (lam > 830)] == 0)
    assert S.CIE_Y_NORMALIZATION == pytest.approx(mi.MI_CIE_Y_NORMALIZATION, rel=1e-12)
    assert S.CIE_D65_NORMALIZATION == pytest.approx(mi.MI_CIE_D65_NORMALIZATION, rel=1e-12)
    assert close(S.xyz_to_srgb(np.eye(3)), np.array([list(mi.xyz_to_srgb(mi.Color3f(*e))) for e in np.eye(3)]),
                 1e-6)[0]


def test_ior_names_match_mitsuba():
    for name, value in S.IOR_TABLE.items():
        eta = mi.traverse(mi.load_dict({"type": "dielectric", "int_ior": name, "ext_ior": "vacuum"}))["eta"]
        assert S.ior(name) == value and close(value, eta, 1e-6)[0], name
        assert S.ior(name.upper()) == value
    with pytest.raises(Exception, match="Valid choices are") as e:
        mi.load_dict({"type": "dielectric", "int_ior": "no such glass"})
    listed = re.search(r"Valid choices are:(.*)", str(e.value)).group(1).split(", ")
    assert listed == list(S.IOR_TABLE)


def test_ior_numbers_and_errors():
    assert S.ior(1.7) == 1.7 and S.ior(2) == 2.0 and S.ior(np.float32(1.5)) == 1.5
    for bad in (0, -1.5, float("nan"), float("inf")):
        with pytest.raises(ValueError, match=r"^value: .*positive"):
            S.ior(bad)
    with pytest.raises(ValueError, match=r"^value: unknown .*bk7.*diamond"):
        S.ior("crown glass")
    for bad in (True, None, [1.5]):
        with pytest.raises(TypeError, match="^value: "):
            S.ior(bad)


def test_conductors_match_mitsuba():
    files = os.listdir(os.path.join(os.path.dirname(mi.__file__), "data", "ior"))
    assert sorted(S.CONDUCTORS) == sorted({f.rsplit(".", 2)[0] for f in files} | {"none"})
    worst = 0.0
    for name in S.CONDUCTORS:
        params = mi.traverse(mi.load_dict({"type": "conductor", "material": name}))
        eta, k = S.conductor_ior(name)
        for ours, key in ((eta, "eta.value"), (k, "k.value")):
            ok, err = close(ours, np.broadcast_to(np.array(params[key], dtype=float), 3))
            assert ok, (name, key, ours, params[key])
            worst = max(worst, err)
    np.testing.assert_array_equal(np.concatenate(S.conductor_ior("none")), [0, 0, 0, 1, 1, 1])


def test_conductor_data_is_mitsubas_spd_files():
    folder = os.path.join(os.path.dirname(mi.__file__), "data", "ior")
    for name in ("Au", "Cu_palik", "TiO2-e", "a-C"):
        table = S._conductor_tables()[name]
        for col, part in ((1, "eta"), (2, "k")):
            wl, v = S.load_spd(os.path.join(folder, f"{name}.{part}.spd"))
            np.testing.assert_array_equal(table[:, 0], wl)
            np.testing.assert_array_equal(table[:, col], v)


def test_conductor_errors():
    with pytest.raises(ValueError, match=r"^material: unknown conductor 'au'.*'Au'"):
        S.conductor_ior("au")
    with pytest.raises(TypeError, match="^material: "):
        S.conductor_ior(None)


def test_blackbody_is_refused_by_rgb_variants():
    """If this starts failing, Mitsuba evaluates black bodies in RGB: compare blackbody_rgb with it."""
    tex = mi.load_dict({"type": "blackbody", "temperature": 3000.0})
    with pytest.raises(RuntimeError, match="non-spectral"):
        tex.eval(mi.SurfaceInteraction3f())


def test_planck_matches_mitsuba_spectral():
    lam = np.array([360.0, 412.5, 555.0, 700.0, 829.0, 830.0, 600.1, 480.0])
    with mi.scoped_set_variant("scalar_spectral"):
        for temperature in (1500.0, 6500.0):
            tex = mi.load_dict({"type": "blackbody", "temperature": temperature})
            si = mi.SurfaceInteraction3f()
            theirs = []
            for quad in lam.reshape(-1, 4):
                si.wavelengths = mi.Spectrum(quad)
                theirs.extend(tex.eval(si))
            assert close(S.planck(lam, temperature), theirs, 1e-5, 0)[0], temperature


@pytest.mark.parametrize("temperature", [3000.0, 6500.0])
def test_blackbody_rgb_matches_mitsuba_spectral_render(temperature):
    """Render (scalar_spectral) a camera inside a constant black-body environment: the pixel's
    expected value is blackbody_rgb.  16 x 2^16 samples: <= 8e-4 relative standard error (the blue;
    measured), so 4e-3 is 5 standard errors; fixed seeds, so deterministic."""
    scene = {"type": "scene", "integrator": {"type": "direct"},
             "sensor": {"type": "perspective", "film": {"type": "hdrfilm", "width": 1, "height": 1,
                                                        "pixel_format": "rgb", "rfilter": {"type": "box"}},
                        "sampler": {"type": "independent", "sample_count": 2 ** 16}},
             "env": {"type": "constant", "radiance": {"type": "blackbody", "temperature": temperature}}}
    with mi.scoped_set_variant("scalar_spectral"):
        scene_obj = mi.load_dict(scene)
        pixels = [np.array(mi.render(scene_obj, seed=seed), dtype=float).ravel() for seed in range(16)]
    ok, err = close(S.blackbody_rgb(temperature), np.mean(pixels, axis=0), 4e-3, 0)
    assert ok, (temperature, S.blackbody_rgb(temperature), np.mean(pixels, axis=0))


def test_blackbody_errors():
    for bad in (0, -10.0, float("nan")):
        with pytest.raises(ValueError, match="^temperature: "):
            S.blackbody_rgb(bad)
    with pytest.raises(TypeError, match="^temperature: "):
        S.blackbody_rgb("hot")


def test_parse_spectrum():
    assert S.parse_spectrum(" 0.5 ") == 0.5 and S.parse_spectrum("-1e-3") == -1e-3
    for text in ("400:0.78, 500:0.3", "400:0.78 500:0.3", "400:0.78,500:0.3\n"):
        wl, v = S.parse_spectrum(text)
        np.testing.assert_array_equal(wl, [400, 500])
        np.testing.assert_array_equal(v, [0.78, 0.3])


BAD = {"": "empty", "400:0.5": "one wavelength:value pair", "400:0.5, 300:0.2": "increase strictly",
       "400:0.5 400:0.6": "increase strictly", "400-0.5, 500:1": "not one wavelength:value pair",
       "400:0.5:1, 500:1": "not one wavelength:value pair", "abc": "not a number",
       "400:x, 500:1": "not a number", "1_0": "not a number"}
NON_FINITE = ("nan", "400:nan, 500:1", "400:inf, 500:1", "-Infinity")


@pytest.mark.parametrize("text", list(BAD) + list(NON_FINITE))
def test_parse_spectrum_errors(text):
    why = BAD.get(text, "not finite")
    with pytest.raises(ValueError, match=rf"^text: .*value=.*{why}"):
        S.parse_spectrum(text)
    if text in BAD:                             # Mitsuba refuses these too (it accepts NaN silently)
        with pytest.raises(Exception):
            mitsuba_rgb(text, "reflectance")


def test_argument_errors():
    with pytest.raises(TypeError, match="^text: "):
        S.parse_spectrum(0.5)
    with pytest.raises(ValueError, match="^kind: .*reflectance, emission, unbounded"):
        S.spectrum_to_rgb([400, 500], [1, 1], kind="albedo")
    with pytest.raises(ValueError, match="^values: "):
        S.spectrum_to_rgb([400, 500], [1, 1, 1])
    with pytest.raises(ValueError, match="^wavelengths: .*increase"):
        S.spectrum_to_rgb([500, 400], [1, 1])
    with pytest.raises(ValueError, match="^wavelengths: .*finite"):
        S.spectrum_to_rgb([400, np.nan], [1, 1])
    with pytest.raises(TypeError, match="^value: "):
        S.spectrum_property_rgb(None)
    with pytest.raises(ValueError, match="^xyz: "):
        S.xyz_to_srgb([1, 2])
