"""UGR of a designed room's whole installation (CIE 117 at the standard observers), the
glare and background terms of a part of it (:func:`glare_terms`: the accents' are
constants of the general lighting's programme, :mod:`.accentglare`), and of its general
lighting dimmed beside accents (:func:`glare_parts`, :func:`ugr_at`).

UGR rates the installation **new** (CIE 117; EN 12464-1's UGR limits hold for the
installation in new condition, as the luminaire makers' UGR tables, which know no
maintenance factor): the luminaires' luminance at their (designed) output and the
background luminance from the light they give new, both without the maintenance factor.
Until round 12 the background was taken maintained (x MF) with the luminance new: a mix
that read every room 8 log10(1 / MF) high (+0.78 at MF 0.8), conservative but costing
watts where UGR binds (tests/core/design/test_design_radiance.py: Radiance's CIE 117
figure in the new condition)."""
import numpy as np


def room_ugr(model, droom, luminaires):
    """Worst UGR over the CIE 117 standard observers (None: nothing in view); luminaires
    without a luminous area are rated as CIE 147 small sources."""
    from invrad_wb.core.output.glare import observers, ugr
    if not luminaires:
        return None
    obs = observers(droom)
    if not obs:
        return None
    eyes = np.array([e for e, _ in obs])
    views = np.array([v for _, v in obs])
    lb = model.indirect_at(eyes, views, luminaires)       # new condition (module doc)
    values = [ugr(luminaires, e, v, b) for (e, v), b in zip(obs, lb)]
    values = [u for u in values if u is not None]
    return max(values) if values else None


def ugr_note(rd, droom):
    """Why a room's UGR is what it is, where the reader needs telling."""
    from invrad_wb.core.output.glare import SMALL_SOURCE_M2, is_small_source, observers
    small = sorted({lum.extra.get("type") for lum in rd.luminaires if is_small_source(lum)})
    if rd.ugr is None and rd.luminaires:
        why = ("no CIE 117 observer position lies inside the room's outline"
               if not observers(droom) else "no luminaire is in any observer's view")
        rd.notes.append(f"UGR not computable: {why}")
    elif small:
        rd.notes.append(f"UGR: {', '.join(small)} give no luminous area (or one under"
                        f" {SMALL_SOURCE_M2} m2): rated as CIE 147 small sources (UGR from"
                        " the intensity towards the eye), an upper bound for a larger"
                        " opening")


def glare_terms(model, droom, luminaires, covering=None):
    """(glare sums ``L^2 omega / p^2`` (O,), background lux (O,), new) of
    ``luminaires`` at the CIE 117 observers, as :func:`room_ugr` counts them: the
    background is the interreflected light at the eye (the direct light left out), and
    light adds up, so a part's terms add to another's (``covering``:
    :meth:`.evaluate.RoomModel.solve`). None where no observer stands in the room."""
    from invrad_wb.core.output.glare import observers, ugr
    obs = observers(droom)
    if not obs:
        return None
    eyes = np.array([e for e, _ in obs])
    views = np.array([v for _, v in obs])
    # ugr() at a background of pi/4 lx is 8 log10 of the sum itself
    out = [ugr(luminaires, e, v, 0.25 * np.pi) for e, v in obs]
    sums = np.array([0.0 if u is None else 10.0 ** (u / 8.0) for u in out])
    return sums, model.indirect_at(eyes, views, luminaires, covering)


def glare_parts(model, droom, general, accents):
    """Per CIE 117 observer, the glare sums (``L^2 omega / p^2``) and the background
    illuminances of the general lighting and of the accents apart
    (:func:`glare_terms`): the general lighting dimmed by f scales its sum by f^2 and its
    background by f (light adds up), so UGR at every dimming level follows from these
    four arrays (:func:`ugr_at`). None where no observer stands in the room."""
    g = glare_terms(model, droom, general)
    if g is None:
        return None
    return g + glare_terms(model, droom, accents)


def ugr_at(parts, f):
    """The worst observer's UGR with the general lighting dimmed by ``f`` and the accents
    as they are (-inf where nothing is in view)."""
    from invrad_wb.core.output.glare import ugr_from_sum
    sg, bg, sa, ba = parts
    u = ugr_from_sum(f * f * sg + sa, f * bg + ba)
    return float(np.nanmax(u)) if np.any(np.isfinite(u)) else -np.inf
