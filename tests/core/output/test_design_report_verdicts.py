"""What the design report's compliance table colours: a value with a limit is green (met)
or red (not met); a value without a limit (UGR where neither the spec nor the room type
gives one) is plain text, not green as if it had been judged and passed. Made-up designs
(no search), no PDF: fast."""
import re
from types import SimpleNamespace

import pytest

from invrad_wb.core.output import design_report as D

from test_design_report_groups import GRID, OUTPUTS, _result, _room


def _ugr_cell(html):
    """The UGR cell of the first room of the Rooms table (the 11th cell of the row)."""
    table = html.split("<h2>Rooms</h2>", 1)[1].split("</table>", 1)[0]
    row = re.findall(r"<tr><td class=\"l\">.*?</tr>", table, re.S)[0]
    cells = re.findall(r"<td([^>]*)>(.*?)</td>", row, re.S)
    return cells[10]


@pytest.mark.parametrize("ugr, limit, want", [(30.6, None, None), (18.7, 19, "pass"),
                                              (22.4, 19, "fail")])
def test_the_ugr_cell_is_coloured_only_against_a_limit(tmp_path, ugr, limit, want):
    rd = _room(GRID, OUTPUTS)
    rd.metrics.emax, rd.metrics.surfaces = float(rd.metrics.lux.max()), {}
    rd.requirement = SimpleNamespace(lux=500.0, u0=0.6, height_m=0.75, margin_m=0.5,
                                     source="spec")
    rd.ugr, rd.ugr_limit = ugr, limit
    result = _result(rd)
    result.spec.maintenance_factor = 0.8
    index = D.write_design_report(result, str(tmp_path / "r"), pdf=False)
    attrs, text = _ugr_cell(open(index).read())
    assert text.strip() == f"{ugr:.1f}"
    got = re.search(r'class="(\w+)"', attrs)
    assert (got.group(1) if got else None) == want
    # the room summary gives no verdict either where there is no limit
    row = [s for s in D.summary_rows(rd) if s["item"].startswith("UGR")][0]
    assert row["verdict"] == {None: "-", "pass": "pass", "fail": "FAIL"}[want]


def test_notes_write_square_metres_as_the_tables_do(tmp_path):
    # the notes come from the design as plain text ('24.0 m2', 'W/m2'); the page's
    # tables write m²: the office's report mixed both on one page
    rd = _room(GRID, OUTPUTS)
    rd.metrics.emax, rd.metrics.surfaces = float(rd.metrics.lux.max()), {}
    rd.requirement = SimpleNamespace(lux=500.0, u0=0.6, height_m=0.75, margin_m=0.5,
                                     source="spec")
    rd.notes = ["surface goal on the floor at (3.00, 2.00, 0.00) m (2501 target points,"
                " 24.0 m2): 354 lx for 319 lx", "deep dimming: 5.0 W/m2 drawn"]
    result = _result(rd)
    result.spec.maintenance_factor = 0.8
    html = open(D.write_design_report(result, str(tmp_path / "r"), pdf=False)).read()
    notes = html.split('<ul class="notes">', 1)[1].split("</ul>", 1)[0]
    assert "24.0 m²" in notes and "5.0 W/m²" in notes
    assert not re.search(r"\bm2\b", notes), notes
