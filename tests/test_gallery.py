"""The README gallery (``experiments/make_gallery.py``) is consistent with the repository.

Fast checks only -- the experiments themselves run in ``test_notebooks.py``: the README
section markers are there, every image the section shows exists in ``docs/gallery/``, and
every chosen figure is a file its script writes (its name appears in the script's source).
"""
from __future__ import annotations

import importlib.util
import re
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def _load_gallery():
    spec = importlib.util.spec_from_file_location("experiments_make_gallery",
                                                  ROOT / "experiments" / "make_gallery.py")
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module          # dataclasses look their module up here
    spec.loader.exec_module(module)
    return module


gallery = _load_gallery()


def _section(text: str) -> str:
    assert text.count(gallery.START) == 1 and text.count(gallery.END) == 1, "gallery markers"
    start, end = text.index(gallery.START), text.index(gallery.END)
    assert start < end
    return text[start:end]


def _images(section: str) -> list[str]:
    return re.findall(r'src="([^"]+)"', section) + re.findall(r"!\[[^\]]*\]\(([^)\s]+)", section)


def test_readme_has_gallery_section_before_layout():
    text = gallery.README.read_text()
    section = _section(text)
    assert gallery.HEADING + "\n" in text
    assert text.index(gallery.HEADING) < text.index(gallery.START) < text.index("## Layout")
    assert _images(section), "the gallery section shows no images"


def test_readme_gallery_images_exist():
    section = _section(gallery.README.read_text())
    for rel in _images(section):
        path = ROOT / rel
        assert path.is_file(), f"README gallery shows {rel}, which does not exist"
        assert path.stat().st_size > 0, rel
        assert path.stat().st_size < 2 * gallery.MAX_BYTES, f"{rel} is too large"
        assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n", f"{rel} is not a PNG"


def test_readme_gallery_matches_docs_gallery():
    """Every PNG in docs/gallery belongs to a GALLERY entry and is shown in the README."""
    shown = set(_images(_section(gallery.README.read_text())))
    entries = {gallery.gallery_path(e).relative_to(ROOT).as_posix() for e in gallery.GALLERY}
    for png in sorted(gallery.GALLERY_DIR.glob("*.png")):
        rel = png.relative_to(ROOT).as_posix()
        assert rel in entries, f"{rel} is not a gallery entry"
        assert rel in shown, f"{rel} is missing from the README gallery; run make_gallery.py"
    assert shown <= entries


@pytest.mark.parametrize("entry", gallery.GALLERY, ids=[e.script for e in gallery.GALLERY])
def test_gallery_entry_names_a_figure_its_script_writes(entry):
    script = gallery.script_path(entry)
    shown = gallery.gallery_path(entry).exists()
    if not script.exists():
        assert not shown, f"docs/gallery has a figure for {entry.script} but no script"
        pytest.skip(f"vrlab/experiments/{entry.script}.py not written yet")
    assert entry.caption and entry.title
    if entry.png is None:
        pytest.skip(f"no figure chosen for {entry.script} yet")
    assert entry.png.endswith(".png")
    assert f'"{entry.png}"' in script.read_text(), f"{entry.script}.py never writes {entry.png}"
    assert shown, f"docs/gallery/{entry.script}.png missing; run experiments/make_gallery.py"


def test_entries_unique():
    names = [e.script for e in gallery.GALLERY]
    assert len(names) == len(set(names))


def test_update_readme_inserts_before_layout_and_is_idempotent(tmp_path):
    readme = tmp_path / "README.md"
    readme.write_text("# x\n\n## Usage\n\ntext\n\n## Layout\n\nfiles\n")
    assert gallery.update_readme(readme)
    text = readme.read_text()
    assert text.index("## Usage") < text.index(gallery.HEADING) < text.index(gallery.START) \
        < text.index(gallery.END) < text.index("## Layout")
    assert text.endswith("## Layout\n\nfiles\n")
    assert not gallery.update_readme(readme)
    assert readme.read_text() == text
