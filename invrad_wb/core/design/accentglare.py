"""The general lighting designed again beside accents whose glare breaks the UGR limit.

The search and the per-group programme (:mod:`.refine`) design the general lighting
alone; the accents (painted spots, :mod:`.accent`, :mod:`.accents`) come after, lit for
their own spots. An accent seen from a CIE 117 observer adds its glare sum to the room's
and is diluted only by the background luminance at the eye, which the general lighting
gives nearly all of: an office whose general lighting alone gives UGR 18.5 may read 19.7
with a bright accent panel by its back wall. Less glare from the general lighting does
not cure it; more background light does (more luminaires or a higher output).

Light adds up, so the accents' glare sums ``T0`` and background lux ``B0`` at each
observer are constants of the general lighting's UGR rows, ``0.25 pi (sum_g s_g T_g +
T0) <= K (sum_g x_g B_g + B0)`` (:func:`.refine.ugr_rows`): the per-group programme
then finds the least power of general lighting (outputs, and the count and positions of
the search's other layouts) under which the whole installation meets the limit. The
background is counted as :func:`.roomglare.room_ugr` counts it (the interreflected light
at the eye, :func:`.roomglare.glare_terms`), so the programme and the judge agree; the
room is finished again with the answer (accents lit again beside the new general
lighting) and judged on the whole installation (:func:`beside_accents`); the design keeps
the least power of those that comply.
"""
from dataclasses import replace

from invrad_wb.core.design.refine import refine
from invrad_wb.core.design.roomglare import glare_terms


def accents_of(luminaires):
    """The accent luminaires (``extra['role'] == 'accent'``) among a room's."""
    return [lum for lum in luminaires if lum.extra.get("role") == "accent"]


def general_beside_accents(search, cand, met, accents, covering=None):
    """(Candidate, Metrics, layouts solved) of the least-power general lighting whose UGR
    with ``accents`` (fixed: positions, aim and output) is within the search's limit, by
    the per-group programme (:func:`.refine.refine`: ``cand``'s own layout first, then
    the fast model's cheapest others); None where the room has no UGR limit, no observer,
    or no dimmable entry to solve for, or where nothing meets it. ``met.glare`` of the
    answer is the whole installation's (accents added). ``covering``: the luminaires
    whose openings cover the ceiling for the accents' background (default: the
    accents)."""
    if search.ugr_max is None or not accents:
        return None
    if not search.dimming or not any(e.dimming[0] < 1.0 for e in search.entries):
        return None
    model = search.model
    fixed = glare_terms(model, model.droom, accents, covering)
    if fixed is None:
        return None
    saved = search.fixed_glare
    search.fixed_glare = fixed
    try:
        # the layout as designed no longer counts as met: the programme starts afresh
        # from it (solved per group) and the search's cheapest others
        c, m, tried = refine(search, replace(cand, ok=False), met)
    finally:
        search.fixed_glare = saved
    if c is None or not c.ok or m is None or m.glare is None:
        return None
    return c, m, tried


#: the general lighting is designed again for the accents' glare at most this often
#: (the accents, lit again beside it, may differ from those it was designed for)
ACCENT_REFITS = 2


def beside_accents(rd, search, cand, met, finish, notes):
    """The room's state (``vars(rd)``) with its general lighting designed again for the
    accents' glare, where they take the whole installation over the UGR limit: the
    accents' glare and background are constants of the per-group programme
    (:func:`general_beside_accents`, from the layout ``cand``, ``met``), the
    room is finished again with its answer (``finish(cand, met, exact_solves)``: accents
    lit again beside it, judged on the whole installation). None where that does not
    comply; ``rd`` is left as it was either way. ``notes``: the room's notes before it
    was finished."""
    if rd.compliant or rd.verdicts.get("UGR") is not False:
        return None
    first, out = dict(vars(rd)), None
    for _ in range(ACCENT_REFITS):
        accents = accents_of(rd.luminaires)
        if not accents:
            break
        got = general_beside_accents(search, cand, met, accents, covering=rd.luminaires)
        if got is None:
            break
        rd.notes, rd.spots, rd.accent_watts = list(notes), [], 0.0
        finish(got[0], got[1], first["exact_solves"] + got[2])
        if rd.compliant:
            w0 = first["candidate"].watts + first["accent_watts"]
            rd.notes.append(f"general lighting designed again for the accents' glare"
                            f" (UGR {first['ugr']:.1f} with the accents beside the general"
                            f" lighting designed alone, {w0:.1f} W): UGR {rd.ugr:.1f},"
                            f" {rd.watts:.1f} W")
            out = dict(vars(rd))
            break
        if rd.verdicts.get("UGR") is not False:
            break                        # something else fails now
    vars(rd).update(first)
    return out
