"""The Design message in the report view (no FreeCAD: describe_design reads a summary)."""
from types import SimpleNamespace

from invrad_wb.app import pipeline
from invrad_wb.gui import runner

_SMALL = ("UGR: {} give no luminous area (or one under 0.005 m2): rated as CIE 147 small"
          " sources (UGR from the intensity towards the eye), an upper bound for a larger"
          " opening")


def _res(rooms):
    return SimpleNamespace(luminaires=[1, 2, 3], building=SimpleNamespace(rooms=rooms),
                           summary={"report": "r.html", "design": {
                               "total_watts": 30.0, "compliant": True, "rooms": rooms}})


def test_point_source_glare_note_said_once_in_plain_words():
    rooms = [{"name": n, "compliant": True, "em_lux": 510, "u0": 0.6, "watts": 10,
              "requirement": {"lux": 500, "u0": 0.4}, "notes": [_SMALL.format(t)]}
             for n, t in (("Kueche", "Downlight A"), ("Bad", "Downlight A, Panel B"),
                          ("Flur", "Panel B"))]
    rooms[2]["notes"].append("too dark: something")
    lines = runner.describe_design(_res(rooms))
    text = "\n".join(lines)
    assert "give no luminous area" not in text and "CIE 147" not in text
    ugr = [ln for ln in lines if "point sources" in ln]
    assert len(ugr) == 1 and "Downlight A, Panel B" in ugr[0], lines
    assert "    too dark: something" in lines          # other notes kept per room
    assert sum(ln.startswith("  ") and "meets its requirements" in ln for ln in lines) == 3


def test_small_source_types_reads_only_the_ugr_note():
    assert pipeline.small_source_types(_SMALL.format("A, B")) == ["A", "B"]
    assert pipeline.small_source_types("UGR not computable: no observer") is None


def test_locate_message_says_the_point_source_note_once():
    summary = {"luminaires": [{"room_name": "A"}, {"room_name": "B"}], "rooms": [
        {"room": n, "verdict": {"met": True, "words": "meets its targets",
                                "notes": [_SMALL.format("Downlight A"), "keep this"]}}
        for n in ("A", "B")]}
    lines = pipeline.describe_rooms(summary)
    assert sum("point sources (Downlight A" in ln for ln in lines) == 1, lines
    assert not any("give no luminous area" in ln for ln in lines)
    assert lines.count("    keep this") == 2
