"""Build the README gallery: one key figure per experiment script, copied to ``docs/gallery/``.

For every entry of ``GALLERY`` whose module exists in ``vrlab/experiments/``, run its
``main(tmp_dir / name, full=...)``, take the chosen PNG from what it wrote, shrink it if it is
over ``MAX_BYTES`` (Pillow, which matplotlib already depends on) and save it as
``docs/gallery/<name>.png``.
A script may define ``gallery_numbers(out) -> dict``, which reads the numbers of its caption
from the CSV files its ``main`` wrote; they are saved next to the figure as
``docs/gallery/<name>.json`` and fill the caption's ``{placeholders}`` (so no number in such a
caption is typed by hand).
Then (re)write the README section between ``<!-- gallery:start -->`` and
``<!-- gallery:end -->`` with one row per figure present in ``docs/gallery/`` (a script that
does not exist yet is skipped with a message; re-run this script once it does).

Run ``python experiments/make_gallery.py [--full] [--only NAME ...] [--no-readme | --readme-only]``.
The captions' numbers come from the default (quick) runs.
"""
from __future__ import annotations

import argparse
import importlib.util
import io
import json
import re
import sys
import tempfile
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
EXPERIMENTS = ROOT / "vrlab" / "experiments"
GALLERY_DIR = ROOT / "docs" / "gallery"
README = ROOT / "README.md"
START, END = "<!-- gallery:start -->", "<!-- gallery:end -->"
HEADING = "## Gallery"
MAX_BYTES = 250_000     # keep each gallery PNG below this
MAX_WIDTH = 1200        # pixels; wider figures are downscaled


@dataclass(frozen=True)
class Entry:
    script: str          # vrlab/experiments/<script>.py
    png: str | None      # file written by that script's main(); None: not chosen yet
    notebook: str        # vrlab/notebooks/<notebook>.ipynb (may not exist yet)
    title: str
    caption: str


GALLERY: list[Entry] = [
    Entry("importance_sampling", "importance_sampling_convergence.png", "01_importance_sampling",
          "Importance sampling",
          "RMSE against n for sin x on [0, π/2] and x²·1[x > ½]: a density shaped like the "
          "integrand (p ∝ x; uniform on [½, 1]) lowers the whole line, the slope stays that of "
          "Monte Carlo (fitted {slope_lo} to {slope_hi}; dashed: theory). For sin the one-sample "
          "variance drops from {sin_uniform} to {sin_linear} ({sin_ratio}×)."),
    Entry("cosine_sampling", "cosine_sampling_renders.png", "02_cosine_sampling",
          "Cosine-weighted sampling",
          "Cornell box at {spps} spp with uniform-hemisphere, cosine, light and MIS (power) "
          "sampling, all at one automatic exposure. Uniform and cosine directions rarely hit the "
          "small light, so most pixels stay black. On ∫cos θ dω, cosine sampling has zero "
          "variance; uniform sampling measures {var_uniform} (closed form π²/3 = {var_uniform_theory})."),
    Entry("light_surfaces", "light_surfaces_direction_pdfs.png", "03_light_surfaces",
          "Light surfaces: area to solid angle",
          "Density of directions towards a box and an ellipsoid light, p_w = Σ_hits p_A d²/|cos θ|: "
          "a closed light is crossed twice, and only the sum over both hits integrates to 1 "
          "(within {both_max_error}; first hit alone: {first_box} for the box, {first_ellipsoid} "
          "for the ellipsoid)."),
    Entry("mis", "mis_veach.png", "04_multiple_importance_sampling",
          "Multiple importance sampling",
          "Veach's glossy plates at {spp} spp, two evaluations per camera ray for every method: BSDF "
          "sampling and light sampling (two samples each), and MIS (one of each) with the balance and "
          "the power heuristic; bottom: the region key (plate 1 roughest … 4 sharpest, light A smallest "
          "… D largest, α read from the scene) and the relMSE per region. Per region MIS's relMSE is at "
          "most {balance_max}× (balance; worst: {balance_worst}) and {power_max}× (power; worst: "
          "{power_worst}) that of the better single technique, and below both single techniques in "
          "{balance_wins} (balance) and {power_wins} (power) of {regions} regions."),
    Entry("antithetic_crn", "antithetic_crn_render.png", "05_antithetic_crn",
          "Antithetic variates and common random numbers",
          "Direct lighting of a floor under a square light, {spp} spp: antithetic cosine pairs (u, 1 − u: "
          "the second direction mirrored about the normal) against two independent cosine samples per "
          "ray. Variance factor 1 + ρ, measured (closed form): {floor} ({floor_theory}) over the floor, "
          "{edge} ({edge_theory}) around the light's edge, {centre} ({centre_theory}) under its centre, "
          "where both directions of a pair hit the light together. On ∫₀¹ eˣ the factor is {exp_factor} "
          "(closed form {exp_theory}); common random numbers cut the variance of ∫eˣ − ∫e^(1.1x) "
          "{crn_gain}×."),
    Entry("control_variates", "control_variates_sweep.png", "06_control_variates",
          "Control variates",
          "Variance per sample against the correlation ρ of f and the control h, at equal N and at "
          "equal cost (dots: measured, lines: theory). α = 1 beats plain MC only for "
          "ρ > {alpha1_equal_n} (theory {alpha1_equal_n_theory}), at equal cost for "
          "ρ > {alpha1_equal_cost} (theory {alpha1_equal_cost_theory}); the optimal α always helps "
          "at equal N, σ²(1 − ρ²), and at equal cost for ρ > {optimal_equal_cost} "
          "(theory {optimal_equal_cost_theory})."),
    Entry("ris", "ris_many_lights.png", "07_resampled_importance_sampling",
          "Resampled importance sampling",
          "{lights} sphere lights, {spp} spp, one shadow ray per sample. Resampling M = {m} uniformly "
          "drawn light candidates towards their unshadowed contribution cuts the relMSE from "
          "{uniform} (light chosen uniformly) and {power} (by power) to {ris}; candidates drawn by "
          "power: {ris_power}."),
    Entry("sampling_patterns", "sampling_patterns_convergence.png", "08_sampling_patterns",
          "Sampling patterns",
          "RMSE against n with fitted slopes (dashed: theory): Monte Carlo {mc_1d}, jittered "
          "{jittered_1d} in 1D and {jittered_2d} in 2D, LHS {lhs_2d}, and scrambled Halton "
          "{halton_2d} and Sobol {sobol_2d} on a smooth 2D integrand."),
    Entry("discrete_sampling", "discrete_sampling_timings.png", "09_discrete_sampling",
          "Discrete sampling",
          "Draw and build cost against table size n = {n_lo} … {n_hi}. The alias table's draw cost "
          "(O(1)) grows only {alias_growth}× over that range; CDF binary search (O(log n)) and "
          "NumPy's Generator.choice are {cdf_factor}× and {choice_factor}× slower at n = {n_hi}. "
          "Timings depend on the machine."),
    Entry("metropolis_hastings", "metropolis_hastings_tv.png", "10_metropolis_hastings",
          "Metropolis–Hastings",
          "Total-variation distance of the MH histogram to the target image. With small steps "
          "only, the chain never leaves its start blob, so TV stays at {tv_trapped} (the mass "
          "outside it: {outside}). With {p_lo} or {p_hi} large steps it converges ({tv_lo} and "
          "{tv_hi} after {steps} steps); i.i.d. sampling is the ideal ({tv_iid})."),
    Entry("gradient_domain", "gradient_domain_relmse.png", "11_gradient_domain",
          "Gradient-domain rendering",
          "relMSE against a reference on the {scenes} built-in scenes at {size} (bars: {spp_hi} spp, mean of "
          "{reps_hi} seeds): the plain render, the same at equal render time (a CRN gradient sample "
          "measured {ratio_min}–{ratio_max}× the cost of a plain one), and the screened-Poisson "
          "reconstructions (α = {alpha}). At equal time, L1 wins on {l1_wins_hi} at {spp_hi} spp and on "
          "{l1_wins_lo} at {spp_lo} spp; L2 wins on {l2_wins_hi} and is up to {l2_worst_factor_hi}× "
          "worse ({l2_worst_hi}), where small bright lights and highlights give outlier gradients that "
          "it spreads."),
    Entry("environment_lighting", "environment_lighting_renders.png", "12_environment_lighting",
          "Environment lighting",
          "A diffuse and a glossy sphere under a sky with a small sun (2° radius), {spp} spp and two evaluations per "
          "camera ray for every method. relMSE: BSDF sampling {bsdf} (it rarely finds the sun), light sampling of the map "
          "uniformly {uniform} and by luminance × sin θ {luminance} ({gain}× lower; its error mostly in the glossy "
          "reflection), MIS {balance} (balance), {power} (power) and {optimal} (optimal weights, fitted per "
          "pixel)."),
    Entry("restir", "restir_many_lights.png", "13_restir",
          "From RIS to ReSTIR",
          "{lights} sphere lights at {size}, {spp} spp, M = {m} light candidates per pixel; relMSE over the pixels that "
          "see no light against a mis-power reference. Spatial reuse ({k} neighbours, pairwise MIS) lowers RIS's relMSE "
          "from {RIS_uniform} to {ReSTIR_uniform} with uniform light selection, {RIS_power} to {ReSTIR_power} by power "
          "and {RIS_bvh} to {ReSTIR_bvh} with the light BVH, but it traces {rays} shadow rays per sample instead of one: "
          "relMSE × seconds goes from {RIS_uniform_t} to {ReSTIR_uniform_t}, {RIS_power_t} to {ReSTIR_power_t} and "
          "{RIS_bvh_t} to {ReSTIR_bvh_t} (best at equal time: {best}). On a closed-form row of {row_pixels} occluded pixels "
          "reuse multiplies the variance per pass by {row_var_ratio} (pairwise; largest |z| {row_pairwise_z}), while "
          "the naive 1/M weights darken it by {row_1m_bias} (pooled z = {row_1m_z})."),
]


def script_path(entry: Entry) -> Path:
    return EXPERIMENTS / f"{entry.script}.py"


def gallery_path(entry: Entry) -> Path:
    return GALLERY_DIR / f"{entry.script}.png"


def numbers_path(entry: Entry) -> Path:
    return GALLERY_DIR / f"{entry.script}.json"


def caption(entry: Entry) -> str:
    """The entry's caption, its ``{placeholders}`` filled from ``docs/gallery/<name>.json``."""
    path = numbers_path(entry)
    return entry.caption.format(**json.loads(path.read_text())) if path.exists() else entry.caption


def load(name: str):
    module = importlib.import_module(f"vrlab.experiments.{name}")
    return module


def shrink_png(src: Path, dst: Path, max_bytes: int = MAX_BYTES, max_width: int = MAX_WIDTH) -> int:
    """Copy ``src`` to ``dst``; if it is over ``max_bytes``, downscale it (at most ``max_width``
    pixels wide, smaller until it fits) and store it with a 256-colour palette.  Return its size."""
    dst.parent.mkdir(parents=True, exist_ok=True)
    data = src.read_bytes()
    if len(data) > max_bytes:
        from PIL import Image

        with Image.open(src) as im:
            img = im.convert("RGB")
        width = min(img.width, max_width)
        while True:
            out = img if width == img.width else img.resize(
                (width, max(1, round(img.height * width / img.width))), Image.LANCZOS)
            buf = io.BytesIO()
            out.quantize(256).save(buf, format="PNG", optimize=True)
            if buf.tell() <= max_bytes or width <= 300:
                break
            width = int(width * 0.8)
        data = buf.getvalue()
    dst.write_bytes(data)
    return len(data)


def build_one(entry: Entry, tmp: Path, full: bool) -> Path | None:
    if not script_path(entry).exists():
        print(f"skip {entry.script}: vrlab/experiments/{entry.script}.py does not exist yet")
        return None
    print(f"run {entry.script} ...", flush=True)
    module = load(entry.script)
    res = module.main(tmp / entry.script, full=full)
    files = list(res.get("files", []))
    png = entry.png
    if png is None:
        pngs = [f for f in files if f.endswith(".png")]
        if not pngs:
            print(f"skip {entry.script}: its main() wrote no PNG")
            return None
        png = pngs[0]
        print(f"note {entry.script}: no figure chosen in GALLERY yet; using {png} "
              f"(choose among {pngs})")
    elif png not in files:
        raise RuntimeError(f"{entry.script}.main() did not report {png}; it wrote {files}")
    dst = gallery_path(entry)
    size = shrink_png(tmp / entry.script / png, dst)
    if hasattr(module, "gallery_numbers"):
        numbers = module.gallery_numbers(tmp / entry.script)
        numbers_path(entry).write_text(json.dumps(numbers, indent=1, ensure_ascii=False) + "\n")
        print(f"wrote {numbers_path(entry).relative_to(ROOT)} (caption numbers)")
    print(f"wrote {dst.relative_to(ROOT)} ({size / 1024:.0f} KB) from {png}")
    return dst


def section_lines() -> list[str]:
    """Markdown for the README gallery section: one row per figure present in docs/gallery."""
    rows = []
    for e in GALLERY:
        path = gallery_path(e)
        if not path.exists():
            continue
        rel = path.relative_to(ROOT).as_posix()
        nb = ROOT / "vrlab" / "notebooks" / f"{e.notebook}.ipynb"
        src = f"[`vrlab/experiments/{e.script}.py`](vrlab/experiments/{e.script}.py)"
        if nb.exists():
            src += f"<br>[`vrlab/notebooks/{e.notebook}.ipynb`](vrlab/notebooks/{e.notebook}.ipynb)"
        img = f'<a href="{rel}"><img src="{rel}" width="360" alt="{e.title}"></a>'
        rows.append(f"| {img} | **{e.title}.** {caption(e)} | {src} |")
    return [
        "One key figure per experiment script (click for full size). Regenerate them with",
        "`python experiments/make_gallery.py` (`--full` for the large runs, `--only NAME` for one).",
        "",
        "| Figure | What it shows | Made by |",
        "| --- | --- | --- |",
        *rows,
    ]


def update_readme(readme: Path = README) -> bool:
    """(Re)write the gallery section between the markers; add it before ``## Layout`` if absent."""
    text = readme.read_text()
    body = "\n".join([START, *section_lines(), END])
    if START in text and END in text:
        new = re.sub(re.escape(START) + r".*?" + re.escape(END), lambda _: body, text, count=1,
                     flags=re.DOTALL)
    else:
        anchor = "\n## Layout"
        if anchor not in text:
            raise RuntimeError("README.md has no '## Layout' heading to put the gallery before")
        new = text.replace(anchor, f"\n{HEADING}\n\n{body}\n{anchor}", 1)
    if new != text:
        readme.write_text(new)
    return new != text


def main(argv: list[str] | None = None) -> list[Path]:
    ap = argparse.ArgumentParser(description=__doc__.strip().splitlines()[0])
    ap.add_argument("--full", action="store_true", help="publication-quality sample counts")
    ap.add_argument("--only", nargs="+", metavar="NAME", help="only these scripts")
    ap.add_argument("--no-readme", action="store_true", help="do not rewrite README.md")
    ap.add_argument("--readme-only", action="store_true",
                    help="run nothing; rewrite the README section from docs/gallery")
    args = ap.parse_args(argv)
    names = [e.script for e in GALLERY]
    if args.only:
        unknown = sorted(set(args.only) - set(names))
        if unknown:
            ap.error(f"unknown gallery entries {unknown}; choose from {names}")
    entries = [e for e in GALLERY if (not args.only or e.script in args.only) and not args.readme_only]
    written = []
    with tempfile.TemporaryDirectory(prefix="vrlab-gallery-") as tmp:
        for entry in entries:
            path = build_one(entry, Path(tmp), args.full)
            if path is not None:
                written.append(path)
    if not args.no_readme:
        changed = update_readme()
        print("README.md gallery section", "updated" if changed else "unchanged")
    total = sum(p.stat().st_size for p in GALLERY_DIR.glob("*.png"))
    print(f"docs/gallery: {len(list(GALLERY_DIR.glob('*.png')))} PNGs, {total / 1024:.0f} KB")
    return written


if __name__ == "__main__":
    sys.exit(0 if main() is not None else 1)
