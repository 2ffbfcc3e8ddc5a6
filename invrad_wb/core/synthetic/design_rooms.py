"""Rooms of different shapes and requirements for the design benchmark and tests.

Each entry: a name, a scene builder (reflectances ceiling/walls/floor 0.7/0.5/0.2 unless
stated), the work-plane requirement and the mounting. The catalogue is a plausible range
of LED downlights and high-bays (flux, system watts); none of it is tuned to a room.
"""
from invrad_wb.core.synthetic import generate as g

CATALOGUE = [
    {"name": "DL-1000", "flux_lm": 1000, "watts": 8.5, "mount_height_m": [2.0, 6.0]},
    {"name": "DL-2000", "flux_lm": 2000, "watts": 15.5, "mount_height_m": [2.0, 6.0]},
    {"name": "DL-3500", "flux_lm": 3500, "watts": 26.0, "mount_height_m": [2.0, 6.0]},
    {"name": "HB-12000", "flux_lm": 12000, "watts": 85.0, "mount_height_m": [4.0, 20.0]},
]


def _box(size, cell=0.25, rho=(0.7, 0.5, 0.2)):
    return g.with_reflectances(g.box_room(size=size, cell=cell), *rho)


def _l(size, cut, cell=0.25, rho=(0.7, 0.5, 0.2)):
    return g.with_reflectances(g.l_room(size=size, cut=cut, cell=cell), *rho)


ROOMS = {
    "office": (lambda: _box((6.0, 4.5, 2.8)), {"lux": 500, "u0": 0.6}),
    "classroom": (lambda: _box((9.0, 7.2, 3.2)), {"lux": 500, "u0": 0.6}),
    "corridor": (lambda: _box((14.0, 1.8, 2.6)), {"lux": 100, "u0": 0.4}),
    "bathroom": (lambda: _box((2.8, 2.2, 2.5), rho=(0.8, 0.7, 0.3)), {"lux": 200, "u0": 0.4}),
    "open_plan": (lambda: _l((16.0, 11.0, 3.0), (9.0, 5.5), cell=0.35),
                  {"lux": 500, "u0": 0.6}),
    "workshop": (lambda: _box((18.0, 12.0, 7.0), cell=0.4, rho=(0.5, 0.3, 0.2)),
                 {"lux": 500, "u0": 0.6}),
}


def spec_dict(name, catalogue=CATALOGUE, dimming=None):
    """The design spec of one room (room id 0); ``dimming`` adds a range to every entry."""
    cat = [dict(e, dimming=list(dimming)) if dimming else dict(e) for e in catalogue]
    return {"maintenance_factor": 0.8, "catalogue": cat,
            "rooms": {"0": {"work_plane": dict(ROOMS[name][1], height_m=0.75,
                                                margin_m=0.5)}}}
