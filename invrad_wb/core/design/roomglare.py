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
figure in the new condition).

UGR counts what the observer **sees** (CIE 117's sum runs over the luminaires in view;
Radiance and evalglare see nothing else): in an L, a room with columns or partitions, a
luminaire behind the inner corner or a column adds nothing, and one partly hidden adds the
share of its luminous area the eye sees (:func:`seen_shares`: the 2 x 2 Gauss points of its
luminous rectangle, by the same segment test through the room's occluders as its direct
light on the grids; a disk as the square of its area, a small source by its centre). Until
round 13 every luminaire counted: in the L with a column of
tests/core/design/test_design_radiance.py, 4 luminaires of the other leg behind the inner
corner put the observer at (3, 4.5) looking -y about 0.5 high. A convex room has no
occluders: every luminaire is wholly seen, the same figures as before.
"""
import math

import numpy as np

from invrad_wb.core.design.openings import half_sides
from invrad_wb.core.forward.occlusion import segments_occluded
from invrad_wb.core.model.aiming import photometric_frame


def seen_shares(model, eye, positions, normals, half=None, c0=None):
    """(L,) share of each luminous area the eye sees past the room's occluders.

    Parameters
    ----------
    model : evaluate.RoomModel (its occluders ``bvh``, None in a convex room)
    eye : (3,) float64, metres
    positions, normals : (L, 3) float64, luminaire centres and facing directions
    half : (half along C0, half along C90) metres of the luminous rectangle, or None (a
        small source: its centre)
    c0 : (3,) float64 or None, the C0 direction (:func:`.aiming.photometric_frame`)

    Returns
    -------
    (L,) float64 in [0, 1] (the share of the rectangle's 2 x 2 Gauss points with a clear
    segment to the eye), or None where nothing in the room can block a sight line.
    """
    if model.bvh is None:
        return None
    P = np.asarray(positions, dtype=np.float64).reshape(-1, 3)
    N = np.asarray(normals, dtype=np.float64).reshape(-1, 3)
    if len(P) == 0:
        return np.zeros(0)
    # the same luminaire in many layouts of the search is tested once: within a call, and
    # across calls (the search's table of every layout, then refine's candidates, each
    # its layout's positions for each observer: the L with its column of
    # tests/core/design/test_design_radiance.py made 1076 calls, 1.2 s of its 11 s
    # design, before the model kept them)
    uniq, inv = np.unique(np.round(np.c_[P, N], 9), axis=0, return_inverse=True)
    inv = inv.reshape(-1)
    eye = np.asarray(eye, dtype=np.float64)
    keys = np.ascontiguousarray(uniq).view(np.dtype((np.void, uniq.itemsize * 6))).ravel()
    kept = _share_cache(model, eye, half, c0)
    out = np.full(len(uniq), np.nan)
    for table, shares in kept["tables"]:
        at = np.minimum(np.searchsorted(table, keys), len(table) - 1)
        hit = table[at] == keys
        out[hit] = shares[at[hit]]
    small = kept["small"]
    todo = np.flatnonzero(np.isnan(out))
    if small and len(todo):
        got = np.array([small.get(keys[i].tobytes(), np.nan) for i in todo])
        out[todo] = got
        todo = todo[np.isnan(got)]
    if len(todo):
        out[todo] = _shares(model, eye, uniq[todo, :3], uniq[todo, 3:], half, c0)
        if len(todo) > SHARE_TABLE_MIN:       # a table: sorted keys, searched
            order = np.argsort(keys[todo])
            kept["tables"].append((keys[todo][order], out[todo][order]))
        else:
            small.update((keys[i].tobytes(), float(out[i])) for i in todo)
    return out[inv]


#: a call of :func:`seen_shares` that traces more luminaires than this keeps them as a
#: sorted table (the search's table of every layout: an open plan's 2331 layouts hold
#: 50 k positions per observer and type, 2.8 MB so, tens of MB in a dict)
SHARE_TABLE_MIN = 256


def _share_cache(model, eye, half, c0):
    """What :func:`seen_shares` keeps on ``model`` for one eye, opening and C0:
    {'tables': [(sorted keys, shares)], 'small': {key bytes: share}} (fresh where the
    model takes no attributes)."""
    key = (eye.tobytes(), None if half is None else tuple(float(h) for h in half),
           None if c0 is None else np.asarray(c0, dtype=np.float64).tobytes())
    try:
        caches = model.__dict__.setdefault("_seen_share_cache", {})
    except AttributeError:
        caches = {}
    return caches.setdefault(key, {"tables": [], "small": {}})


def _shares(model, eye, P, N, half, c0):
    """(L,) :func:`seen_shares` of distinct luminaires, by the segment test."""
    if half is None:
        off = np.zeros((1, 2))
    else:
        a, b = half[0] / math.sqrt(3.0), half[1] / math.sqrt(3.0)   # Gauss-Legendre
        off = np.array([[-a, -b], [a, -b], [-a, b], [a, b]])
    pts = np.empty((len(P), len(off), 3))
    for key in np.unique(np.round(N, 9), axis=0):
        rows = np.flatnonzero(np.all(np.abs(N - key) < 1e-8, axis=1))
        u, w = photometric_frame(N[rows[0]], c0)
        pts[rows] = P[rows, None, :] + off[:, :1] * u + off[:, 1:] * w
    flat = pts.reshape(-1, 3)
    hidden = segments_occluded(model.bvh, np.broadcast_to(eye, flat.shape), flat,
                               model.backend)
    return 1.0 - hidden.reshape(len(P), len(off)).mean(axis=1)


def luminaire_shares(model, eye, luminaires):
    """:func:`seen_shares` of a list of luminaires (each its own opening and C0)."""
    if model.bvh is None or not luminaires:
        return None
    return np.array([seen_shares(model, eye, lum.position[None], lum.normal[None],
                                 half_sides(lum.radius_m, getattr(lum, "photometry", None)),
                                 lum.c0)[0] for lum in luminaires])


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
    values = [ugr(luminaires, e, v, b, luminaire_shares(model, e, luminaires))
              for (e, v), b in zip(obs, lb)]
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
    out = [ugr(luminaires, e, v, 0.25 * np.pi, luminaire_shares(model, e, luminaires))
           for e, v in obs]
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
