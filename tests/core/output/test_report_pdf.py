"""The reports' PDF (WeasyPrint) read back with poppler's tools: pages, text, images.

.ci/setup.sh installs both (Debian's weasyprint and poppler-utils); these tests fail
rather than skip without them, so that a machine set up without them is noticed.
"""
import os
import shutil
import subprocess

import numpy as np
import pytest

from invrad_wb.core.synthetic import generate as g
from invrad_wb.core.model.luminaires import Luminaire
from invrad_wb.core.forward.render import render
from invrad_wb.core.output import document
from invrad_wb.core.output.images import read_image
from invrad_wb.core.output.report import build_report


def _tool(name):
    path = shutil.which(name)
    assert path, f"{name} (poppler-utils) is not installed: run .ci/setup.sh"
    return path


def _run(*cmd):
    return subprocess.run(cmd, check=True, capture_output=True, text=True).stdout


def _two_rooms():
    s, _ = g.floor_of_rooms(rooms=((4.0, 3.0), (5.0, 4.0)), cell=0.25)
    lums = []
    for r in s.rooms:
        f = s.faces[s.face_room == r].reshape(-1)
        lo, hi = s.vertices[f].min(axis=0), s.vertices[f].max(axis=0)
        lums.append(Luminaire([0.5 * (lo[0] + hi[0]), 0.5 * (lo[1] + hi[1]), hi[2]],
                              [0, 0, -1], 3000.0, room=int(r)))
    E = render(s, lums, interreflection=False, backend="numpy")
    return s, lums, E.copy(), E


def test_verification_pdf_has_cover_room_pages_text_and_images(tmp_path):
    s, lums, target, E = _two_rooms()
    names = {0: "Küche", 1: "Wohnen & Essen"}
    paths = build_report(s, target, 0.7 * E, lums, str(tmp_path / "rep"), room_names=names,
                         project="Haus <Nord>")
    assert paths.pdf and os.path.isfile(paths.pdf) and not paths.notes
    info = _run(_tool("pdfinfo"), paths.pdf)
    pages = int([l for l in info.splitlines() if l.startswith("Pages:")][0].split()[1])
    size = [l for l in info.splitlines() if l.startswith("Page size:")][0]
    assert "595.276 x 841.89" in size                       # A4
    # a cover, at least one page per room, the appendix
    assert pages >= 1 + len(names) + 1
    text = _run(_tool("pdftotext"), "-layout", paths.pdf, "-")
    first = text.split("\f")[0]
    assert "Haus <Nord>" in first and "0 of 2" in first     # 70 %: neither room meets Em
    for n in names.values():
        assert n in text
        # each room starts a page whose first line is its name
        assert any(p.strip().startswith(n) for p in text.split("\f")), n
    assert "Technical appendix" in text and "page 2 of" in text
    # three figures per room, embedded as images
    listing = _run(_tool("pdfimages"), "-list", paths.pdf).splitlines()[2:]
    assert len(listing) >= 3 * len(names)
    # the first room's page, rendered: mostly white paper with coloured figures
    png = tmp_path / "page"
    _run(_tool("pdftoppm"), "-r", "40", "-png", "-f", "2", "-l", "2", paths.pdf, str(png))
    img = read_image(next(tmp_path.glob("page*.png")))[..., :3]
    white = np.all(img > 0.97, axis=2).mean()
    coloured = (np.ptp(img, axis=2) > 0.25).mean()
    assert 0.3 < white < 0.97 and coloured > 0.02


def test_without_weasyprint_the_html_is_written_and_the_reason_given(tmp_path,
                                                                     monkeypatch):
    s, lums, target, E = _two_rooms()

    def missing():
        raise document.PdfUnavailable("no PDF: WeasyPrint cannot be loaded (test)")

    monkeypatch.setattr(document, "pdf_engine", missing)
    paths = build_report(s, target, E, lums, str(tmp_path), write_exr=False)
    assert os.path.isfile(paths.html) and paths.pdf == ""
    assert not (tmp_path / "report.pdf").exists()
    assert paths.notes == ["no PDF: WeasyPrint cannot be loaded (test)"]


def test_design_report_pdf(tmp_path):
    from invrad_wb.core.design.design import design
    from invrad_wb.core.design.spec import spec_from_dict
    s, _ = g.floor_of_rooms(rooms=((4.0, 3.0), (5.0, 4.0)), cell=0.4)
    sp = spec_from_dict({"catalogue": [{"name": "DL-2000", "flux_lm": 2000, "watts": 16}],
                         "rooms": {"*": {"work_plane": {"lux": 300, "u0": 0.4}}}})
    res = design(s, sp, room_names={0: "Bad", 1: "Büro"})
    html = res.write_report(tmp_path / "rep", title="Design", project="Test house")
    pdf = os.path.join(os.path.dirname(html), "report.pdf")
    text = _run(_tool("pdftotext"), pdf, "-")
    assert "Test house" in text and "Bad" in text and "Büro" in text
    assert "Luminaire schedule" in text
    assert len(_run(_tool("pdfimages"), "-list", pdf).splitlines()[2:]) >= 3


@pytest.mark.parametrize("engine", ["weasyprint"])
def test_the_pdf_engine_is_installed(engine):
    assert document.pdf_engine().__name__ == engine
