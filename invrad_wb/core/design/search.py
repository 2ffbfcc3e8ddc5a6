"""The design search of one room: the compliant layout of least installed power.

Candidates are symmetric grids (:mod:`.layouts`) of one catalogue entry, or of two entries
(one on the end columns, one inside), each optionally dimmed as one group. The fast model
(:mod:`.evaluate`) ranks all of them; the cheapest that complies is checked with the exact
model, the fast model learns from it, and the ranking is repeated until the cheapest
fast-compliant candidate has been checked exactly (or no cheaper one is left). Verdicts
come from the exact model only.

Compliance of a room (maintained values): ``Em >= lux`` and ``Emin / Em >= u0`` on the
calculation grid, the same on the walls' and the ceiling's grids (their own requirements,
EN 12464-1:2021 5.2.3), and the direct light on every "must stay dark" point at most the
room's shade limit. A common dimming level serves the strictest of the three means.
"""
from dataclasses import dataclass, field
import itertools
import math

import numpy as np

from invrad_wb.core.design.evaluate import (Layout, entry_c0, luminaires_of, turned_entries,
                                            unit_response)
from invrad_wb.core.design.openings import half_sides
from invrad_wb.core.design.spec import SurfaceRequirement
from invrad_wb.core.design.roomglare import luminaire_shares, seen_shares
from invrad_wb.core.output.glare import observers, ugr_from_sum, unit_glare
from invrad_wb.core.design.layouts import grid_geometries, zone_geometries

#: exact solves per room at most
MAX_EXACT = 10
#: relative slack of the fast model's compliance test (the exact check decides)
FAST_SLACK = 0.0
#: assumed utilisation factors of the lumen method, used only to bound the counts tried
_UF_LOW, _UF_HIGH = 0.35, 1.1
#: luminaires per room at most
MAX_COUNT = 400
#: surface grids judged on the exact checks only, not by the fast model's ranking: the
#: immediate surroundings lie next to the work plane and follow it; their fast figures,
#: corrected per point by the last exact check, would turn away layouts that the exact
#: check finds compliant (:mod:`.cylindrical`); the background area beyond them likewise
#: (:mod:`.background`)
EXACT_ONLY = ("surroundings", "background")   # and "surroundings (desks)": name prefixes
#: UGR margin of the fast model's glare test (its background luminance is that of a
#: reference layout; the exact check decides)
UGR_FAST_MARGIN = 0.0


def _spacing_log_ratio(g):
    """|log(spacing along s / spacing along t)| of a grid (0 = square); a single row or
    column counts the room's width as its spacing."""
    # the rows and columns kept (a grid's outer ones may be dropped near the walls)
    s, t = (np.unique(np.round(g.plan[:, k], 6)) for k in (0, 1))
    ss = (s[-1] - s[0]) / (len(s) - 1) if len(s) > 1 else 2 * s[0]
    st = (t[-1] - t[0]) / (len(t) - 1) if len(t) > 1 else 2 * t[0]
    return round(abs(math.log(max(ss, 1e-3) / max(st, 1e-3))), 3)


@dataclass
class Candidate:
    geom: object
    entries: tuple          # (entry index for class 0, for class 1)
    dim: float              # common output fraction
    watts: float
    em: float               # fast-model maintained Em, lx (after dimming)
    u0: float
    shade_max: float
    ok: bool
    #: (L,) output fraction of each luminaire where they differ (:mod:`.refine`; then
    #: ``dim`` is the power-weighted mean output), or None: all at ``dim``
    dims: np.ndarray = field(default=None, repr=False, compare=False)

    def key(self):
        g = self.geom
        return (g.ns, g.nt, g.fs, g.ft, g.count, g.clearance, self.entries)


@dataclass
class Metrics:
    """Exact figures of a design on its room's grid (maintained lux)."""
    em: float
    emin: float
    emax: float
    u0: float
    shade_max: float
    lux: np.ndarray = field(repr=False, default=None)

    direct: np.ndarray = field(repr=False, default=None)
    #: name -> (Em, Emin, U0) of each surface grid (walls, ceiling), maintained lux
    surfaces: dict = field(default_factory=dict)
    #: worst UGR over the CIE 117 observers (None: not computed or nothing in view)
    ugr: float = None
    #: (glare sums (O,), background lux (O,)) at full output, for re-dimming
    glare: tuple = field(repr=False, default=None)
    #: maintained (Ez (k,), Eh (k,)) at the cylindrical-illuminance points, or None
    #: (:mod:`.cylindrical`)
    cyl: tuple = field(repr=False, default=None)

    @property
    def cylindrical(self):
        """Figures of Ez (:func:`.cylindrical.figures`) or None."""
        from invrad_wb.core.design.cylindrical import figures
        return None if self.cyl is None else figures(*self.cyl)

    @classmethod
    def of(cls, lux, direct, layout):
        """Figures of maintained lux at the work-plane grid, at the surface grids
        (area-weighted mean) and at points that must stay dark (judged on their direct
        light: interreflection lights every surface of a lit room a little).
        ``layout``: :class:`~invrad_wb.core.design.evaluate.Layout` or the work-plane
        count (no surfaces; the rest must stay dark)."""
        lay = Layout.of(layout)
        wp = lux[:lay.n_wp]
        em = float(np.mean(wp))
        sh = float(np.max(direct[lay.shade0:])) if len(lux) > lay.shade0 else 0.0
        surf = {}
        for name, (sl, w) in lay.parts.items():
            e = lux[sl]
            m = float(np.sum(w * e) / max(float(np.sum(w)), 1e-12))
            surf[name] = (m, float(e.min()), float(e.min() / m) if m > 0 else 0.0)
        return cls(em, float(wp.min()), float(wp.max()),
                   float(wp.min() / em) if em > 0 else 0.0, sh, lux, direct, surf)

    def surface_ok(self, surface_reqs):
        """{name: bool} of each surface grid against its requirement."""
        return {k: bool(self.surfaces[k][0] >= r.lux - 1e-9
                        and self.surfaces[k][2] >= r.u0 - 1e-9)
                for k, r in surface_reqs.items() if k in self.surfaces}


def complies(em, u0, shade, req, shade_limit, slack=0.0, surf=None, surf_reqs=None):
    """Boolean array: requirement met (Em, U0 with relative ``slack``, shade; and each
    surface's (Em, U0) in ``surf`` against ``surf_reqs``)."""
    ok = ((em >= req.lux * (1.0 - slack)) & (u0 >= req.u0 - slack)
          & (shade <= shade_limit * (1.0 + slack)))
    for name, (s_em, s_u0) in (surf or {}).items():
        r = (surf_reqs or {}).get(name)
        if r is not None:
            ok = ok & (s_em >= r.lux * (1.0 - slack)) & (s_u0 >= r.u0 - slack)
    return ok


class RoomSearch:
    """Search state of one room (see module docstring).

    Parameters
    ----------
    model : evaluate.RoomModel
    req : spec.WorkPlaneRequirement
    room_spec : spec.RoomSpec
    entries : list of spec.CatalogueEntry allowed in the room
    photometry : dict entry name -> photometry object or None
    mixed : bool, also try two entries per layout
    dimming : bool, use the entries' dimming ranges
    fractions : edge fractions to try (layouts.EDGE_FRACTIONS; (0.5,) = classic grids)
    """

    #: the share by which a dimmed design's mean illuminances (work plane, walls, ceiling,
    #: surroundings, Ez) are kept above their minimums (:data:`.spec.DESIGN_MARGIN`; set by
    #: the caller): the output is chosen for ``lux * (1 + margin)``, the verdict is still
    #: taken on ``lux``
    margin = 0.0
    #: :class:`.cylindrical.CylindricalGrid` where the room asks for Ez (set by the
    #: caller); judged on every exact check, not by the fast model
    cylindrical = None
    #: its requirement while searching (relaxed in later stages, see :func:`run_search`)
    cyl_req = None

    def __init__(self, model, req, room_spec, entries, photometry=None, mixed=True,
                 dimming=True, fractions=None):
        shifted = len(model.points) > model.layout.shade0   # points that must stay dark
        self.model, self.req, self.rs = model, req, room_spec
        # the surface grids the model holds, judged against the room's requirements
        self.surf_reqs = {k: v for k, v in getattr(room_spec, "surfaces", {}).items()
                          if k in model.layout.parts}
        self.phot = photometry or {}
        # an entry with a photometry not the same in its C0 and C90 planes is tried laid
        # along the room and across it
        self.entries = turned_entries(list(entries), self.phot)
        self.mixed, self.dimming = mixed, dimming
        droom = model.droom
        self._axes = (droom.axes, droom.size)
        wp_z = droom.floor_z + req.height_m
        need = req.lux * max(droom.floor_area, 1e-6) / model.mf   # lm on the floor area
        # plausible counts per entry: the lumen method with utilisation factors
        # between _UF_LOW and _UF_HIGH (2 more at the top for uniformity)
        # a dimmable entry also as twice as many at half output or less (light spread
        # wider: walls, ceiling and uniformity met for less power)
        self.n_range = [(max(1, int(math.floor(need / (e.flux_lm * _UF_HIGH)))),
                         max(2, int(math.ceil(need / (e.flux_lm * _UF_LOW
                                                      * self._least_output(e)))) + 2))
                        for e in self.entries]
        kw = {"shifted": shifted} if fractions is None else {"fractions": fractions,
                                                             "shifted": shifted}
        # clear of the walls by the luminous opening's half size (a disc's radius, or a
        # photometry file's luminous extent): no panel reaches through a wall. Each half
        # size of the catalogue gets its own layouts (a downlight's grid keeps the outer
        # rows that a panel's must drop); a layout serves the entries it is clear for
        halves = sorted({round(self._half_size(e), 6) for e in self.entries}, reverse=True)
        n_lo = min(r[0] for r in self.n_range)
        n_hi = min(max(r[1] for r in self.n_range), MAX_COUNT)
        self.geoms, seen = [], set()
        for half in halves:
            geoms = grid_geometries(droom, room_spec.mounting, half, wp_z, n_lo, n_hi, **kw)
            if not droom.rectangular:
                # an L (a room of a few rectangles): also one grid per rectangle
                geoms += zone_geometries(droom, room_spec.mounting, half, wp_z, n_lo, n_hi)
            for g in geoms:
                # the same positions as a layout clear for a larger opening: that one
                # serves both
                key = (type(g), g.ns, g.nt, g.fs, g.ft, np.round(g.plan, 6).tobytes())
                if key not in seen:
                    seen.add(key)
                    g.clearance = half
                    self.geoms.append(g)
        radius = halves[0]
        if not self.geoms:
            # a catalogue too weak for the room: its densest grids are the closest designs
            dense = grid_geometries(droom, room_spec.mounting, radius, wp_z, 1, MAX_COUNT,
                                    **kw)
            top = max((g.count for g in dense), default=0)
            self.geoms = [g for g in dense if g.count >= 0.8 * top]
            for g in self.geoms:
                g.clearance = radius
        self.g_count = np.array([g.count for g in self.geoms], dtype=float)
        self.g_ratio = np.array([_spacing_log_ratio(g) for g in self.geoms])
        self.g_fdev = np.array([g.edge_deviation for g in self.geoms])
        self.g_clear = np.array([g.clearance for g in self.geoms], dtype=float)
        self._responses()
        self.ugr_max = getattr(room_spec, "ugr_max", None)
        self.obs = observers(droom)
        self._glare()
        self.eye_ind = {}          # entry name -> (O,) indirect lux per lm at the eyes
        self.checked = {}
        #: (glare sums (O,), background lux (O,)) at the observers of luminaires that
        #: stay as they are beside the layouts searched (a room's accents), or None: the
        #: per-group programme holds the whole installation's UGR (:mod:`.refine`)
        self.fixed_glare = None

    def _least_output(self, e):
        """The output fraction the count range allows for: 1, or 0.5 for an entry the
        search may dim that far."""
        return 0.5 if self.dimming and e.dimming[0] <= 0.5 else 1.0

    def _half_size(self, e):
        """Half the largest side of an entry's luminous opening (m; 0: a point); the grids
        run along the room's axes, and so do a turned entry's sides."""
        if e.radius_m > 0:
            return e.radius_m
        ph = self.phot.get(e.name)
        ext = getattr(ph, "luminous_extent_m", None)
        if ext:
            return 0.5 * max(ext)
        area = getattr(ph, "luminous_area_m2", None)
        return 0.5 * math.sqrt(area) if area else 0.0

    def _optics(self, e):
        return (e.radius_m, e.photometry, e.orientation)

    def _c0(self, e):
        """World C0 of an entry turned along / across the room (None: not turned)."""
        return entry_c0(e, self._axes)

    def _responses(self):
        """Per optical key and class: (G, k) unit-flux direct light sums, and counts."""
        m = self.model
        G = len(self.geoms)
        self.N = np.zeros((G, 2))
        self.S = {}
        if G == 0:
            return
        pos = np.concatenate([g.positions for g in self.geoms])
        nrm = np.concatenate([g.normals for g in self.geoms])
        group = np.concatenate([2 * gi + g.cls for gi, g in enumerate(self.geoms)])
        self.N = np.bincount(group, minlength=2 * G).reshape(G, 2).astype(float)
        order = np.argsort(group, kind="stable")
        gs = group[order]
        block = max(1, 2_000_000 // max(1, len(m.points)))
        for e in self.entries:
            key = self._optics(e)
            if key in self.S:
                continue
            out = np.zeros((2 * G, len(m.points)))
            for b0 in range(0, len(order), block):
                # whole groups per block so reduceat sums each group once
                b1 = min(len(order), b0 + block)
                cols = order[b0:b1]
                r = unit_response(m.points, m.normals, pos[cols], nrm[cols], e.radius_m,
                                  self.phot.get(e.name), self._c0(e))
                st = np.flatnonzero(np.r_[True, gs[b0 + 1:b1] != gs[b0:b1 - 1]])
                np.add.at(out, gs[b0:b1][st], np.add.reduceat(r, st, axis=1).T)
            self.S[key] = out.reshape(G, 2, -1).transpose(1, 0, 2)

    def _area(self, e):
        """Luminous area of an entry (m^2; None: a small source, see glare)."""
        if e.radius_m > 0:
            return math.pi * e.radius_m ** 2
        ph = self.phot.get(e.name)
        return getattr(ph, "luminous_area_m2", None) if ph is not None else None

    def _glare(self):
        """Per optical key and class: (G, O) glare sums at unit flux of every geometry
        for the CIE 117 observers (:func:`~invrad_wb.core.output.glare.unit_glare`)."""
        G, O = len(self.geoms), len(self.obs)
        self.GL = {}
        if G == 0 or O == 0:
            return
        pos = np.concatenate([g.positions for g in self.geoms])
        nrm = np.concatenate([g.normals for g in self.geoms])
        group = np.concatenate([2 * gi + g.cls for gi, g in enumerate(self.geoms)])
        for e in self.entries:
            key = self._optics(e)
            if key in self.GL:
                continue
            out = np.zeros((2 * G, O))
            half = half_sides(e.radius_m, self.phot.get(e.name))
            for o, (eye, view) in enumerate(self.obs):
                seen = seen_shares(self.model, eye, pos, nrm, half, self._c0(e))
                np.add.at(out[:, o], group, unit_glare(eye, view, pos, nrm, self._area(e),
                                                       self.phot.get(e.name), self._c0(e),
                                                       seen))
            self.GL[key] = out.reshape(G, 2, O).transpose(1, 0, 2)

    def fast_ugr(self, pair, sel, dim):
        """(len(sel),) worst UGR over the observers of geometries ``sel`` with entries
        ``pair`` at output ``dim`` (NaN: nothing in view, or no observer)."""
        if not self.GL or not self.eye_ind:
            return np.full(len(sel), np.nan)
        m = self.model
        e0, e1 = self.entries[pair[0]], self.entries[pair[1]]
        g0, g1 = self.GL[self._optics(e0)][0][sel], self.GL[self._optics(e1)][1][sel]
        N = self.N[sel]
        total = (e0.flux_lm ** 2 * g0 + e1.flux_lm ** 2 * g1) * (dim ** 2)[:, None]
        # the background new, as roomglare rates UGR
        lb = dim[:, None] * (np.outer(N[:, 0] * e0.flux_lm, self.eye_ind[e0.key])
                                    + np.outer(N[:, 1] * e1.flux_lm, self.eye_ind[e1.key]))
        u = ugr_from_sum(total, lb)
        with np.errstate(all="ignore"):
            return np.where(np.isnan(u).all(axis=1), np.nan,
                            np.nanmax(np.where(np.isnan(u), -np.inf, u), axis=1))

    def exact_glare(self, luminaires, covering=None):
        """(total (O,), background lux (O,)) of luminaires: the glare sums of
        :func:`unit_glare` and the interreflected light at the eyes, new (as
        :mod:`.roomglare` rates UGR), by an exact solve; ``ugr_from_sum(f^2 total, f lb)``
        is the UGR at output fraction f (``covering``: :meth:`.evaluate.RoomModel.solve`)."""
        if not self.obs or not luminaires:
            return None
        eyes = np.array([e for e, _ in self.obs])
        views = np.array([v for _, v in self.obs])
        total = np.zeros(len(self.obs))
        for o, (eye, view) in enumerate(self.obs):
            seen = luminaire_shares(self.model, eye, luminaires)
            seen = np.ones(len(luminaires)) if seen is None else seen
            for k, lum in enumerate(luminaires):
                e = next(x for x in self.entries if x.name == lum.extra.get("type")
                         and x.orientation == lum.extra.get("orientation"))
                total[o] += lum.flux_lm ** 2 * unit_glare(
                    eye, view, lum.position[None], lum.normal[None], self._area(e),
                    self.phot.get(e.name), lum.c0, seen[k:k + 1])[0]
        lb = self.model.indirect_at(eyes, views, luminaires, covering)     # new
        return total, lb

    def _calibrate_all(self):
        """Indirect light per lumen of each entry, from a middle-sized grid of it (on the
        grids, and at the observers' eyes for UGR)."""
        m = self.model
        med = float(np.median([g.count for g in self.geoms]))
        mid = min(self.geoms, key=lambda g: (g.edge_deviation,
                                             abs(g.count - med)))
        for k, e in enumerate(self.entries):
            lums = luminaires_of(mid.positions, mid.normals, np.full(mid.count, e.flux_lm),
                                 self.entries, np.full(mid.count, k), m.droom.room,
                                 self.phot, self._axes)
            m.calibrate(e.key, lums, None)
            if self.obs:
                eyes = np.array([x for x, _ in self.obs])
                views = np.array([v for _, v in self.obs])
                self.eye_ind[e.key] = (m.indirect_at(eyes, views, lums)
                                        / (e.flux_lm * mid.count))

    def evaluate(self, pair, sel):
        """Fast figures of geometries ``sel`` with entries ``pair`` (class 0, class 1):
        (em, u0, shade, dim, watts, surf) after the common dimming, ``surf`` name ->
        (em, u0) arrays of each surface grid."""
        m, lay = self.model, self.model.layout
        n_wp = lay.n_wp
        e0, e1 = self.entries[pair[0]], self.entries[pair[1]]
        s0, s1 = self.S[self._optics(e0)][0][sel], self.S[self._optics(e1)][1][sel]
        N = self.N[sel]
        direct = m.mf * (e0.flux_lm * s0 + e1.flux_lm * s1)
        ind = (np.outer(N[:, 0] * e0.flux_lm, m.indirect_per_lm[e0.key])
               + np.outer(N[:, 1] * e1.flux_lm, m.indirect_per_lm[e1.key]))
        lux = (direct + m.mf * ind) * m.correction
        em = lux[:, :n_wp].mean(axis=1)
        u0 = lux[:, :n_wp].min(axis=1) / np.maximum(em, 1e-12)
        shade = (direct[:, lay.shade0:].max(axis=1) if lux.shape[1] > lay.shade0
                 else np.zeros(len(em)))
        dmin = max(e0.dimming[0], e1.dimming[0]) if self.dimming else 1.0
        need = self.req.lux / np.maximum(em, 1e-12)
        surf = {}
        for name, (sl, w) in lay.parts.items():
            s_em = lux[:, sl] @ w / max(float(w.sum()), 1e-12)
            surf[name] = (s_em, lux[:, sl].min(axis=1) / np.maximum(s_em, 1e-12))
            r = self.surf_reqs.get(name)
            if r is not None:
                need = np.maximum(need, r.lux / np.maximum(s_em, 1e-12))
        dim = np.clip(need, dmin, 1.0)
        watts = dim * (N[:, 0] * e0.watts + N[:, 1] * e1.watts)
        surf = {k: (v[0] * dim, v[1]) for k, v in surf.items()}
        surf["ugr"] = self.fast_ugr(pair, sel, dim)
        return em * dim, u0, shade * dim, dim, watts, surf

    def _pairs(self):
        n = len(self.entries)
        pairs = [(a, a) for a in range(n)]
        if self.mixed:
            pairs += [(a, b) for a, b in itertools.permutations(range(n), 2)]
        return pairs

    def _count_ok(self, pair):
        """(G,) bool: the geometry's count is in the plausible range of the pair's entries."""
        counts = self.N.sum(axis=1)
        lo = min(self.n_range[k][0] for k in pair)
        hi = max(self.n_range[k][1] for k in pair)
        lo = min(lo, counts.max()) if len(counts) else lo   # clipped grids hold fewer
        ok = (counts >= lo) & (counts <= hi)
        if pair[0] != pair[1]:
            ok &= self.N[:, 1] > 0
        # clear of the walls for the pair's openings
        half = max(round(self._half_size(self.entries[k]), 6) for k in pair)
        return ok & (self.g_clear >= half - 1e-9)

    def table(self):
        """Fast figures of every (geometry, entry pair) candidate, as arrays.

        Returns a dict of (C,) arrays: ``geom``, ``pair`` (index into ``self._pairs()``),
        ``em``, ``u0``, ``shade``, ``dim``, ``watts``, ``ok``; rows sorted best first
        (least watts; ties: fewer luminaires, one entry, square spacing, half spacing).
        """
        names = list(self.model.layout.parts)
        keys = ("geom", "pair", "em", "u0", "shade", "dim", "watts", "ugr",
                *(f"{n}_{q}" for n in names for q in ("em", "u0")))
        cols = {k: [] for k in keys}
        for pi, pair in enumerate(self._pairs()):
            sel = np.flatnonzero(self._count_ok(pair))
            if len(sel) == 0:
                continue
            em, u0, sh, dim, watts, surf = self.evaluate(pair, sel)
            for k, v in zip(keys, (sel, np.full(len(sel), pi), em, u0, sh, dim, watts,
                                   surf["ugr"], *(x for n in names for x in surf[n]))):
                cols[k].append(v)
        t = {k: (np.concatenate(v) if v else np.zeros(0)) for k, v in cols.items()}
        t["geom"] = t["geom"].astype(int)
        t["pair"] = t["pair"].astype(int)
        t["ok"] = complies(t["em"], t["u0"], t["shade"], self.req, self.rs.shade_limit_lux,
                           FAST_SLACK, self._surf(t),
                           {k: v for k, v in self.surf_reqs.items()
                            if not k.startswith(EXACT_ONLY)})
        if self.ugr_max is not None:
            t["ok"] &= ~(t["ugr"] > self.ugr_max + UGR_FAST_MARGIN)   # NaN: none in view
        g = t["geom"]
        mixed = np.array([a != b for a, b in self._pairs()])[t["pair"]] if len(g) else g
        # watts within 0.5 % count as equal: then fewer luminaires win (dimmed layouts
        # of many luminaires draw about what fewer at full output draw)
        w_bucket = np.floor(np.log(np.maximum(t["watts"], 1e-9)) / np.log(1.005))
        order = np.lexsort((t["watts"], self.g_fdev[g], self.g_ratio[g], mixed,
                            self.g_count[g], w_bucket))
        return {k: v[order] for k, v in t.items()}

    def _surf(self, t):
        """{name: (em, u0)} columns of the surface grids in a :meth:`table`."""
        return {n: (t[f"{n}_em"], t[f"{n}_u0"]) for n in self.model.layout.parts}

    def score(self, t):
        """(C,) how close each row comes to compliance: the least of its ratios
        achieved / required (1 or more: met)."""
        req = self.req
        limit = max(self.rs.shade_limit_lux, 1e-9)
        score = np.minimum(np.minimum(t["em"] / req.lux, t["u0"] / max(req.u0, 1e-9)),
                           np.minimum(limit / np.maximum(t["shade"], 1e-12), 1.0))
        for n, (s_em, s_u0) in self._surf(t).items():
            r = self.surf_reqs.get(n)
            if r is not None:
                score = np.minimum(score, np.minimum(s_em / max(r.lux, 1e-9),
                                                     s_u0 / max(r.u0, 1e-9)))
        if self.ugr_max is not None:
            # the factor by which the glare sum exceeds the limit's
            over = np.nan_to_num(t["ugr"] - self.ugr_max, nan=-1.0)
            score = np.minimum(score, np.minimum(1.0, 10.0 ** (-over / 8.0)))
        return score

    def candidate(self, t, row):
        """The :class:`Candidate` of row ``row`` of :meth:`table`."""
        return Candidate(self.geoms[t["geom"][row]], self._pairs()[t["pair"][row]],
                         float(t["dim"][row]), float(t["watts"][row]), float(t["em"][row]),
                         float(t["u0"][row]), float(t["shade"][row]), bool(t["ok"][row]))

    def candidates(self):
        """All candidates with fast figures (list of :class:`Candidate`, best first)."""
        t = self.table()
        return [self.candidate(t, i) for i in range(len(t["geom"]))]

    def luminaires(self, cand):
        g = cand.geom
        idx = np.asarray(cand.entries)[g.cls]
        out = cand.dim if getattr(cand, "dims", None) is None else np.asarray(cand.dims)
        flux = np.array([self.entries[k].flux_lm for k in idx]) * out
        return luminaires_of(g.positions, g.normals, flux, self.entries, idx,
                             self.model.droom.room, self.phot, self._axes)

    def check(self, cand, fast_lux=None):
        """Exact figures of a candidate (cached); re-dims it to the exact Em."""
        key = cand.key()
        if key not in self.checked:
            full = Candidate(cand.geom, cand.entries, 1.0, 0.0, 0, 0, 0, False)
            lums = self.luminaires(full)
            lux, direct = self.model.calibrate(None, lums, fast_lux)
            met = Metrics.of(lux, direct, self.model.layout)
            met.glare = self.exact_glare(lums)
            if met.glare is not None:
                u = ugr_from_sum(*met.glare)
                met.ugr = None if np.isnan(u).all() else float(np.nanmax(u))
            if self.cylindrical is not None:
                met.cyl = self.cylindrical.evaluate(lums)
            self.checked[key] = met
        return self.checked[key]


def _finalise(search, cand, exact_full):
    """Dim a candidate on its exact figures; returns (candidate, metrics) after dimming."""
    e0, e1 = (search.entries[k] for k in cand.entries)
    dmin = max(e0.dimming[0], e1.dimming[0]) if search.dimming else 1.0
    need = search.req.lux / max(exact_full.em, 1e-12)
    for name, r in search.surf_reqs.items():
        need = max(need, r.lux / max(exact_full.surfaces[name][0], 1e-12))
    if search.cyl_req is not None and exact_full.cyl is not None:
        need = max(need, search.cyl_req["lux"] / max(float(np.mean(exact_full.cyl[0])), 1e-12))
    dim = float(np.clip(need * (1.0 + max(search.margin, 0.001)), dmin, 1.0))
    g = cand.geom
    n = np.bincount(g.cls, minlength=2)
    watts = dim * (n[0] * e0.watts + n[1] * e1.watts)
    met = Metrics.of(exact_full.lux * dim, exact_full.direct * dim, search.model.layout)
    met.glare = exact_full.glare
    if exact_full.cyl is not None:      # light adds up: Ez and Eh scale with the output
        met.cyl = (dim * exact_full.cyl[0], dim * exact_full.cyl[1])
    if exact_full.glare is not None:
        u = ugr_from_sum(dim ** 2 * exact_full.glare[0], dim * exact_full.glare[1])
        met.ugr = None if np.isnan(u).all() else float(np.nanmax(u))
    c = Candidate(g, cand.entries, dim, watts, met.em, met.u0, met.shade_max,
                  bool(metrics_comply(met, search)))
    return c, met


def margin_kept(met, search):
    """Whether every mean illuminance of ``met`` keeps the search's margin above its
    minimum (work plane, surfaces, Ez)."""
    k = 1.0 + search.margin
    ok = met.em >= search.req.lux * k - 1e-9
    for name, r in search.surf_reqs.items():
        if name in met.surfaces:
            ok = ok and met.surfaces[name][0] >= r.lux * k - 1e-9
    if search.cyl_req is not None and met.cyl is not None:
        ok = ok and float(np.mean(met.cyl[0])) >= search.cyl_req["lux"] * k - 1e-9
    return bool(ok)


def metrics_comply(met, search):
    """Exact metrics against every requirement of the search's room."""
    surf = {k: (v[0], v[2]) for k, v in met.surfaces.items()}
    ok = complies(met.em, met.u0, met.shade_max, search.req, search.rs.shade_limit_lux,
                  surf=surf, surf_reqs=search.surf_reqs)
    if search.ugr_max is not None and met.ugr is not None:
        ok = ok and met.ugr <= search.ugr_max + 1e-9
    if search.cyl_req is not None and met.cyl is not None:
        from invrad_wb.core.design.cylindrical import complies as cyl_complies
        ok = ok and cyl_complies(met.cylindrical, search.cyl_req)
    return ok


def run_search(search):
    """Best design of a room: (Candidate, Metrics, n_exact). Candidate.ok is the verdict.

    When no layout meets every requirement, the search is repeated without the UGR limit,
    then without the walls' and ceiling's uniformity, then without walls and ceiling: the closest design then meets the work plane
    (and what else it can) rather than trading the work plane's light for a glare or
    surface figure no layout reaches; its verdict is still taken on every requirement.
    """
    search._calibrate_all()
    cyl = search.cylindrical.req if search.cylindrical is not None else None
    full = (search.ugr_max, dict(search.surf_reqs), cyl)
    stages = [full]
    if full[0] is not None:
        stages.append((None, full[1], cyl))
    if full[1] or cyl is not None:
        # the surfaces' (and Ez's) uniformity is a matter of layout, their Em of output:
        # keep the latter where the former cannot be met
        stages.append((None, {k: SurfaceRequirement(r.lux, 0.0, r.source)
                              for k, r in full[1].items()},
                       None if cyl is None else dict(cyl, u0=0.0)))
        stages.append((None, {}, None))
    first = None
    try:
        for ugr_max, surf, cyl_req in stages:
            search.ugr_max, search.surf_reqs, search.cyl_req = ugr_max, surf, cyl_req
            best, closest = _search_once(search)
            if first is None:
                first = closest
            if best is not None:
                break
    finally:
        search.ugr_max, search.surf_reqs, search.cyl_req = full
    if best is None and first is None:
        return None, None, len(search.checked)
    cand, met = best if best is not None else first[:2]
    if not metrics_comply(met, search):
        cand = Candidate(cand.geom, cand.entries, cand.dim, cand.watts, cand.em, cand.u0,
                         cand.shade_max, False)
    return cand, met, len(search.checked)


def _search_once(search):
    """(best, closest) of one pass against the search's current requirements: best is
    (Candidate, Metrics) compliant of least watts or None, closest (Candidate, Metrics,
    score) of the non-compliant ones checked or None."""
    best = None       # (candidate, metrics) exact-compliant of least watts
    closest = None    # best effort when nothing complies
    req = search.req
    for it in range(MAX_EXACT):
        t = search.table()
        if len(t["geom"]) == 0:
            break
        rows = np.flatnonzero(t["ok"])
        if best is not None:
            rows = rows[t["watts"][rows] < best[0].watts - 1e-9]
        todo = next((search.candidate(t, r) for r in rows
                     if search.candidate(t, r).key() not in search.checked), None)
        if todo is None:
            if best is not None or closest is not None:
                break
            score = search.score(t)
            todo = search.candidate(t, int(np.lexsort((t["watts"], -score))[0]))
            if todo.key() in search.checked:
                break
        fast = search.model.fast(*_fast_args(search, todo))
        cand, met = _finalise(search, todo, search.check(todo, fast))
        if cand.ok and (best is None or cand.watts < best[0].watts):
            best = (cand, met)
        score = min([met.em / req.lux, met.u0 / max(req.u0, 1e-9),
                     search.rs.shade_limit_lux / max(met.shade_max, 1e-12)]
                    + [min(met.surfaces[k][0] / max(r.lux, 1e-9),
                           met.surfaces[k][2] / max(r.u0, 1e-9))
                       for k, r in search.surf_reqs.items()]
                    + ([10.0 ** (-(met.ugr - search.ugr_max) / 8.0)]
                       if search.ugr_max is not None and met.ugr is not None else [])
                    + _cyl_score(met, search))
        if not cand.ok and (closest is None or score > closest[2]):
            closest = (cand, met, score)
    return best, closest


def _cyl_score(met, search):
    """[score] of the Ez figures against the search's current Ez requirement, or []."""
    q = search.cyl_req
    if q is None or met.cyl is None:
        return []
    f = met.cylindrical
    return [min(f["em_lux"] / max(q["lux"], 1e-9), f["u0"] / max(q["u0"], 1e-9))]


def _fast_args(search, cand):
    """(response, flux, keys) of a candidate at full output for RoomModel.fast."""
    g = cand.geom
    idx = np.asarray(cand.entries)[g.cls]
    cols = []
    for k in np.unique(idx):
        e = search.entries[k]
        sel = idx == k
        cols.append((unit_response(search.model.points, search.model.normals,
                                   g.positions[sel], g.normals[sel], e.radius_m,
                                   search.phot.get(e.name), search._c0(e)), sel, k))
    resp = np.zeros((len(search.model.points), g.count))
    for r, sel, _ in cols:
        resp[:, sel] = r
    flux = np.array([search.entries[k].flux_lm for k in idx])
    keys = [search.entries[k].key for k in idx]
    return resp, flux, keys


#: regular grids (:func:`classic_grids`) checked exactly at most
GRID_CHECKS = 24
#: ... among those the fast model finds at least this close to compliance (:meth:`score`)
GRID_SCORE = 0.9
#: ... while their fast watts are within this factor of the best compliant one's
GRID_WINDOW = 1.1


def classic_grids(search):
    """The lighting designer's regular grid as a candidate of the search: one catalogue
    entry (laid along and across the room where its photometry is not symmetric), half
    spacing at the walls (one grid per rectangle of a room that is not one), dimmed
    evenly where the entry allows. The fast model ranks them by watts; those it finds
    close to compliance (:data:`GRID_SCORE`) are checked exactly in that order, at most
    :data:`GRID_CHECKS`, until their fast watts pass :data:`GRID_WINDOW` x the best
    compliant one's. The search's design then competes with the best of them, so a
    design never draws more than the best regular grid found (its rows dimmed apart may
    draw less, :mod:`.refine`). Returns (Candidate, Metrics) of the least watts the exact
    model finds compliant (with the search's design margin), or None."""
    t = search.table()
    if len(t["geom"]) == 0:
        return None
    single = np.array([a == b for a, b in search._pairs()])[t["pair"]]
    rows = np.flatnonzero(single & (search.g_fdev[t["geom"]] == 0)
                          & (search.score(t) >= GRID_SCORE))
    best = None
    for r in rows[:GRID_CHECKS]:
        c = search.candidate(t, r)
        if best is not None and c.watts > GRID_WINDOW * best[0].watts:
            break
        fast = search.model.fast(*_fast_args(search, c))
        cand, met = _finalise(search, c, search.check(c, fast))
        if cand.ok and (best is None or cand.watts < best[0].watts):
            best = (cand, met)
    return best


def best_regular_grid(search):
    """The lighting designer's reference: one catalogue entry, an ``ns x nt`` grid with half
    spacing at the walls, no dimming; the compliant one of least watts by the exact model.

    ``search`` must be built with ``fractions=(0.5,)``, ``mixed=False``, ``dimming=False``.
    Candidates are checked exactly in order of watts (not trusting the fast model).
    Returns (Candidate, Metrics) or None when no grid complies.
    """
    search._calibrate_all()
    for cand in search.candidates():
        if cand.em < 0.8 * search.req.lux or cand.u0 < search.req.u0 - 0.2:
            continue  # hopeless by the fast model: not worth an exact solve
        met = search.check(cand)
        if metrics_comply(met, search):
            return cand, met
    return None
