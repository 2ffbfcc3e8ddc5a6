"""Dimming groups of a designed room: its luminaires of one type at one output setting.

The report's plans and schedule, the ``--schedule`` CSV and the result JSON all use these
groups, so that a letter means the same luminaires everywhere. Plain numpy: no plotting.
"""
import numpy as np

from invrad_wb.constants import DEEP_DIMMING


def _group_letter(i):
    """'A'..'Z', then 'AA', 'AB', ... (a room with more than 26 dimming groups)."""
    return chr(65 + i) if i < 26 else _group_letter(i // 26 - 1) + chr(65 + i % 26)


def output_groups(r, catalogue):
    """Dimming groups of a room: its luminaires of one type at one output setting (a whole
    per cent of the type's rated flux; each luminaire's own flux counts, not the type's
    mean), in catalogue order and brightest first. A list of dicts: type, percent,
    fraction (the members' mean output), count, flux_lm and watts (each, at that output),
    watts_total (the members' own watts summed), members (indices into
    ``r.luminaires``), deep (general lighting below ``DEEP_DIMMING``) and label: 'A',
    'B', ... where some type of the room is dimmed apart (more than one output), else ''
    (the type names the group)."""
    cat = {e.name: e for e in catalogue}
    order = [e.name for e in catalogue]
    groups = {}
    for i, lum in enumerate(r.luminaires):
        t = lum.extra.get("type")
        e = cat[t]
        x = lum.flux_lm / max(e.flux_lm, 1e-12)
        groups.setdefault((t, int(round(100 * x))), []).append((i, x))
    keys = sorted(groups, key=lambda k: (order.index(k[0]) if k[0] in order else len(order),
                                         -k[1]))
    apart = len({t for t, _ in keys}) < len(keys)
    n_general = len(r.general_outputs())
    out = []
    for j, k in enumerate(keys):
        e, xs = cat[k[0]], np.array([x for _, x in groups[k]])
        out.append({"type": k[0], "percent": k[1], "fraction": float(xs.mean()),
                    "count": len(xs),
                    "flux_lm": float(e.flux_lm * xs.mean()),
                    "watts": float(e.watts * xs.mean()),
                    "watts_total": float(e.watts * xs.sum()),
                    "members": [i for i, _ in groups[k]],
                    # general lighting below DEEP_DIMMING (accents are not flagged)
                    "deep": any(i < n_general and x < DEEP_DIMMING - 1e-9
                                for i, x in groups[k]),
                    "label": _group_letter(j) if apart else ""})
    return out


def groups_json(r, catalogue, first_index=0):
    """The dimming groups of room design ``r`` (:func:`output_groups`) for the result
    JSON: label, type, percent, count, flux_lm and watts each, watts_total, deep, and the
    members as indices into the JSON's ``luminaires`` list (the room's first luminaire
    there is ``first_index``)."""
    out = []
    for g in output_groups(r, catalogue):
        out.append({"label": g["label"], "type": g["type"], "percent": g["percent"],
                    "count": g["count"], "flux_lm": round(g["flux_lm"], 1),
                    "watts": round(g["watts"], 3), "watts_total": round(g["watts_total"], 3),
                    "deep": bool(g["deep"]),
                    "luminaires": [first_index + i for i in g["members"]]})
    return out
