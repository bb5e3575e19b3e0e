"""Mitsuba 3 reference images for vrlab's built-in direct-lighting scenes.

Renders the SAME built-in XML files with Mitsuba 3 (``scalar_rgb``; ``llvm_ad_rgb``
aborts on this machine's system LLVM 14/15 with "Cannot select ... fmaximum") and its
``direct`` integrator, at a small resolution override and high spp split into ``K``
independent batches (sampler seeds 0..K-1).  Stores, per scene,

    vrlab/render/scenes/mitsuba/<scene>_mean.npy     float32 (H, W, 3)  mean of the K batch means
    vrlab/render/scenes/mitsuba/<scene>_stderr.npy   float32 (H, W, 3)  std(batch means, ddof=1)/sqrt(K)

Only two in-memory edits are made to each XML (the file on disk is not touched):

* the film's width/height are set to the override (the built-in files hard-code them or
  use differently named ``<default>`` parameters);
* ``--black-emitters`` (default on) gives every emitting shape without a ``<bsdf>`` an
  explicit black diffuse BSDF.  That is what Mitsuba 3 does anyway: an emitter without a
  BSDF reflects nothing (checked: bit-identical images with and without this edit on
  veach_mis and many_lights at 64x48, 2048 spp, seed 7), while an emitter *with* a BSDF
  reflects other lights -- and so does vrlab (``tests/test_render_strategies.py``).  The
  edit is kept as a safeguard.

box_ellipsoid is skipped: it uses vrlab's own ``ellipsoid`` shape and ``phong`` BSDF,
which plain Mitsuba 3 does not have.

Usage (takes a few minutes on 2 cores)::

    pip install mitsuba
    python experiments/mitsuba_references.py --width 64 --height 48 --spp 512 --batches 32
"""
from __future__ import annotations

import argparse
import time
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np

SCENES = ("furnace", "cornell_box", "veach_mis", "many_lights")
SCENE_DIR = Path(__file__).resolve().parents[1] / "vrlab" / "render" / "scenes"
OUT_DIR = Path(__file__).resolve().parents[1] / "vrlab" / "render" / "scenes" / "mitsuba"


def scene_xml(name: str, width: int, height: int, black_emitters: bool = True) -> str:
    """The built-in XML of ``name`` with the film resolution overridden (and optionally
    an explicit black BSDF on emitting shapes that have none), as a string for ``mi.load_string``."""
    root = ET.parse(SCENE_DIR / f"{name}.xml").getroot()
    film = root.find("sensor/film")
    for node in film.findall("integer"):
        if node.get("name") == "width":
            node.set("value", str(width))
        elif node.get("name") == "height":
            node.set("value", str(height))
    if black_emitters:
        for shape in root.iter("shape"):
            if shape.find("emitter") is None or shape.findall("bsdf") + shape.findall("ref"):
                continue
            bsdf = ET.SubElement(shape, "bsdf", type="diffuse")
            ET.SubElement(bsdf, "rgb", name="reflectance", value="0")
    return ET.tostring(root, encoding="unicode")


def load(mi, name: str, width: int, height: int, black_emitters: bool = True):
    return mi.load_string(scene_xml(name, width, height, black_emitters), spp=1)


def render_batches(mi, scene, spp: int, batches: int, seed0: int = 0):
    """(mean, stderr) over ``batches`` independent renders of ``spp`` samples each."""
    imgs = np.stack([np.array(mi.render(scene, spp=spp, seed=seed0 + k), dtype=np.float64)[..., :3]
                     for k in range(batches)])
    return imgs.mean(0), imgs.std(0, ddof=1) / np.sqrt(batches)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--scenes", nargs="*", default=list(SCENES))
    ap.add_argument("--width", type=int, default=64)
    ap.add_argument("--height", type=int, default=48)
    ap.add_argument("--spp", type=int, default=512, help="samples per pixel per batch")
    ap.add_argument("--batches", type=int, default=32)
    ap.add_argument("--variant", default="scalar_rgb")
    ap.add_argument("--black-emitters", action=argparse.BooleanOptionalAction, default=True)
    ap.add_argument("--out", type=Path, default=OUT_DIR)
    args = ap.parse_args(argv)

    import mitsuba as mi
    mi.set_variant(args.variant)
    args.out.mkdir(parents=True, exist_ok=True)
    for name in args.scenes:
        t = time.perf_counter()
        scene = load(mi, name, args.width, args.height, args.black_emitters)
        mean, err = render_batches(mi, scene, args.spp, args.batches)
        np.save(args.out / f"{name}_mean.npy", mean.astype(np.float32))
        np.save(args.out / f"{name}_stderr.npy", err.astype(np.float32))
        print(f"{name}: mitsuba {mi.__version__} {args.variant}, {args.width}x{args.height}, "
              f"{args.batches} x {args.spp} spp, mean {mean.mean():.5g}, "
              f"median stderr {np.median(err):.3g}, {time.perf_counter() - t:.1f} s", flush=True)


if __name__ == "__main__":
    main()
