"""The design lines `python -m invrad_wb freecad` prints (cli.freecad_cmd._say_design)."""
from invrad_wb.cli.freecad_cmd import _say_design


def _room(**kw):
    r = {"name": "office", "em_lux": 423.0, "u0": 0.55, "watts": 106.4, "w_per_m2": 4.4,
         "compliant": True, "notes": [], "schedule": {"DL-3500": 11}, "ugr": 18.9,
         "ugr_limit": 19, "requirement": {"lux": 500, "u0": 0.6},
         "surfaces": {"task area: desks": {"em_lux": 505.0, "u0": 0.63,
                                           "required": {"lux": 500, "u0": 0.6}}}}
    r.update(kw)
    return r


def test_task_areas_are_judged_each_not_the_work_plane_over_all():
    lines = []
    _say_design({"rooms": [_room(task_areas=[{"name": "desks"}])], "total_watts": 106.4,
                 "compliant": True}, lines.append)
    assert "task area: desks Em 505 lx (>= 500) U0 0.63 (>= 0.6)" in lines[0]
    assert "423" not in lines[0] and "0.55" not in lines[0]
    lines = []
    _say_design({"rooms": [_room(surfaces={})], "total_watts": 106.4, "compliant": True},
                lines.append)
    assert "Em 423 lx (>= 500), U0 0.55 (>= 0.6)" in lines[0]
