"""Joint refinement of luminaire positions (beyond the thesis).

Vote peaks alone are biased where light overlaps: a point lit by two luminaires (and by
interreflection) votes for the single luminaire that would explain all its light, so peaks
move towards each other and phantom peaks appear between them. Here all luminaires' light is
predicted *together* and the robust deviation of log illuminance over the voting points is
minimised:

    cost = mean_i rho(ln(E_pred_i + eps) - ln(E_target_i + eps)),
    rho(r) = c^2 (sqrt(1 + (r/c)^2) - 1)     (pseudo-Huber, c = ``robust_scale``)

(quadratic for small deviations, linear for large ones: a hot spot or a dark corner keeps
costing in proportion, unlike a saturating Cauchy loss that would ignore them)
    E_pred = sum_k (F cos(theta_l) cos(theta_s) / (pi r^2) V_k + I_k) + E_base

by Levenberg-Marquardt with an analytic Jacobian (iteratively reweighted). Surface
luminaires move in their plane (2 parameters, kept on the plane's faces), mid-air
luminaires in 3-D (kept inside the room). ``I_k`` is luminaire k's own interreflected light
(interreflection is linear in the sources): a uniform estimate from the room's flux balance
for a new candidate, the forward radiosity solve once it is accepted; it is held fixed while
positions move and refreshed when a luminaire has moved. Because each luminaire carries its
own share, adding or removing one changes the indirect light consistently (a single shared
term made the selection oscillate between too many and too few luminaires).

Candidates (vote peaks, best first) are added greedily and kept only if they lower the cost
by a clear margin; afterwards each luminaire is removed again if the cost does not need it
(:mod:`invrad_wb.core.inverse.select`).
The (1+1) evolution strategy of thesis 3.1.2.2 is available as an alternative optimiser.
"""
from dataclasses import dataclass, field

import numpy as np

from invrad_wb import constants as C
from invrad_wb.core.geometry.bvh import segments_occluded_numpy
from invrad_wb.core.inverse import optim
from invrad_wb.core.inverse.tiedparams import tied_fit

#: a luminaire's fitted flux stays within exp(+-this) of the problem's flux
LOG_SCALE_LIMIT = np.log(100.0)

#: :attr:`Light.indirect_grad`: the first-order follow of a luminaire's interreflection
#: reaches at most this far from where it was computed (beyond, it is held at that reach:
#: the refresh after the fit recomputes it); measured smooth over 10 cm (twelve 4000 lm
#: downlights, the derivative the same to 4 digits for steps of 2 mm to 10 cm)
INDIRECT_GRAD_REACH_M = 0.25

#: :meth:`RefineProblem.refresh_indirect` with ``indirect_gradient``: the central
#: difference step of the interreflection's position derivative (m)
INDIRECT_GRAD_STEP_M = 0.02


@dataclass(eq=False)
class Light:
    """A luminaire being refined.

    kind : 'surface' (on map ``map_index``'s plane) or 'free' (mid-air, 3 parameters).
    """

    kind: str
    position: np.ndarray
    normal: np.ndarray
    map_index: int
    plane: int = -1
    peak_score: float = 0.0
    score: float = 0.0
    origin: np.ndarray = None
    u: np.ndarray = None
    v: np.ndarray = None
    indirect: np.ndarray = None        # (k,) lux this luminaire adds by interreflection
    indirect_at: np.ndarray = None     # position it was computed for (None: an estimate)
    #: (k, 3) d indirect / d position (lux per metre, at the problem's flux) at
    #: ``indirect_at``, or None: with it the luminaire's interreflection follows its moves
    #: to first order (:meth:`own_indirect`) and is in the Jacobian; without it the value
    #: is held where it was computed until the next refresh
    #: (:attr:`RefineProblem.indirect_gradient`)
    indirect_grad: np.ndarray = None
    #: this luminaire's flux / the problem's ``flux`` (its light and its ``indirect``, which
    #: is computed for the problem's flux, scale with it)
    flux_scale: float = 1.0
    #: the flux is a parameter of the fit too (its log, after the position's)
    free_flux: bool = False
    #: an aimable luminaire: the normal of the surface it is mounted on (``normal`` is
    #: then its aim, the photometric axis); None: it faces along ``normal``
    mount: np.ndarray = None
    #: the aim is a parameter of the fit too (2 gnomonic coordinates after the position's,
    #: :func:`invrad_wb.core.model.aiming.aim_offset`), its tilt at most ``max_tilt``
    free_aim: bool = False
    max_tilt: float = 70.0
    #: free fluxes: luminaires of one group (>= 0) share one flux (:mod:`.tiedparams`,
    #: :mod:`.locate_ties`); -1: a flux of its own
    flux_group: int = -1

    def facing(self):
        """The direction the luminaire's body faces: its mount normal, else its normal."""
        return self.normal if self.mount is None else self.mount

    def _npos(self):
        return 2 if self.kind == "surface" else 3

    def n_params(self):
        """How many parameters :meth:`params` has (without computing them)."""
        return self._npos() + (2 if self.free_aim else 0) + (1 if self.free_flux else 0)

    def params(self):
        if self.kind == "surface":
            d = self.position - self.origin
            p = [d @ self.u, d @ self.v]
        else:
            p = list(self.position)
        if self.free_aim:
            from invrad_wb.core.model.aiming import aim_offset
            p.extend(aim_offset(self.mount, self.normal))
        if self.free_flux:
            p.append(np.log(self.flux_scale))
        # one array from the values (np.append per part was a tenth of the optimiser's
        # own time in bench_aim's free-flux lobby; the same numbers)
        return np.array(p, dtype=np.float64)

    def with_params(self, p):
        # a shallow copy (the dataclass constructor with its 20 fields was a tenth of a
        # count search's time: every optimiser step unpacks every luminaire twice)
        q = object.__new__(Light)
        q.__dict__.update(self.__dict__)
        if self.kind == "surface":
            q.position = self.origin + p[0] * self.u + p[1] * self.v
        else:
            q.position = np.asarray(p[:3], dtype=np.float64).copy()
        if self.free_aim:
            from invrad_wb.core.model.aiming import aim_of_offset
            n = self._npos()
            q.normal = aim_of_offset(self.mount, p[n:n + 2], self.max_tilt)
        if self.free_flux:
            # min/max, not np.clip: the same value (NaN stays NaN), without np.clip's
            # dispatch on a scalar
            q.flux_scale = float(np.exp(min(max(p[-1], -LOG_SCALE_LIMIT), LOG_SCALE_LIMIT)))
        return q

    def dpos(self):
        """(n_params, 3) derivative of the position w.r.t. the parameters."""
        d = np.stack([self.u, self.v]) if self.kind == "surface" else np.eye(3)
        if self.free_aim:
            d = np.vstack([d, np.zeros((2, 3))])
        return np.vstack([d, np.zeros(3)]) if self.free_flux else d

    def own_indirect(self):
        """(k,) interreflected lux of this luminaire at its flux, or None (with
        :attr:`indirect_grad`: its value where it was computed plus the gradient times the
        move since, the move at most :data:`INDIRECT_GRAD_REACH_M`)."""
        if self.indirect is None:
            return None
        if self.indirect_grad is None or self.indirect_at is None:
            return self.flux_scale * self.indirect
        d = self.position - self.indirect_at
        n = float(np.linalg.norm(d))
        if n > INDIRECT_GRAD_REACH_M:
            d = d * (INDIRECT_GRAD_REACH_M / n)
        return self.flux_scale * (self.indirect + self.indirect_grad @ d)

    def copy(self):
        return Light(**{k: (v.copy() if isinstance(v, np.ndarray) else v)
                        for k, v in self.__dict__.items()})


class _Direct:
    """The lambertian forward model of K luminaires at k points: E (K, k) and the arrays
    its position derivatives are made from (:meth:`RefineProblem._lambertian`)."""

    __slots__ = ("E", "N", "dx", "dy", "dz", "A", "B", "r2", "t")

    def __init__(self, E, N, dx, dy, dz, A, B, r2, t):
        self.E, self.N, self.dx, self.dy, self.dz = E, N, dx, dy, dz
        self.A, self.B, self.r2, self.t = A, B, r2, t


@dataclass
class RefineProblem:
    """What the refinement fits.

    Attributes
    ----------
    positions, normals : (k, 3) float64 voting points
    target : (k,) float64 lux (0 = shade)
    flux : float, lumens per luminaire
    area : (k,) float64 weights (m^2 per point)
    bvh : BVH or None (occluders; None = no occlusion)
    inside : callable(Light) -> Light or None: the luminaire moved into the allowed region
        (e.g. a mid-air luminaire clamped below the ceiling), or None if it cannot be
    occluded_fn : callable(p (n,3), q (n,3)) -> (n,) bool, optional fast occlusion
    indirect : (k,) lux, a base term independent of the luminaires (default 0)
    indirect_estimate : callable(Light) -> (k,) lux, quick interreflection of one luminaire
    indirect_exact : callable(Light) -> (k,) lux, its forward radiosity solve (optional),
        for a luminaire of ``flux`` (scaled by :attr:`Light.flux_scale` where used)
    free_flux : bool, fit each luminaire's flux as well as its position
    photometry : Photometry or None: every luminaire's intensity distribution (I/F in its
        frame); None: lambertian, I/F = cos(theta)/pi. With a distribution the position
        derivatives are central differences (the table is interpolated bilinearly).
    """

    positions: np.ndarray
    normals: np.ndarray
    target: np.ndarray
    flux: float
    area: np.ndarray
    bvh: object = None
    inside: object = None
    occluded_fn: object = None
    robust_scale: float = 0.1
    eps_lux: float = None
    indirect: np.ndarray = None
    indirect_estimate: object = None
    indirect_exact: object = None
    #: fit each luminaire's flux too (``flux`` is then only the starting value and the unit
    #: of :attr:`Light.flux_scale`)
    free_flux: bool = False
    #: the luminaires' intensity distribution (a Photometry; None: lambertian)
    photometry: object = None
    #: fit the aim of aimable luminaires (those with a :attr:`Light.mount`) too
    free_aim: bool = False
    stats: dict = field(default_factory=dict)
    #: :meth:`refresh_indirect` also computes each refreshed luminaire's interreflection
    #: gradient (:attr:`Light.indirect_grad`, two more radiosity solves per position
    #: parameter): the fit then has the interreflection's dependence on the positions in
    #: its model and Jacobian, and its minimum is the likelihood's (held fixed between
    #: refreshes, the fit stops where the direct light's gradient alone is zero: on
    #: every wall and the ceiling the interreflection moves with the luminaire)
    indirect_gradient: bool = False

    def __post_init__(self):
        pos = self.target[self.target > 0]
        if self.eps_lux is None:
            self.eps_lux = max(0.5, 0.02 * float(np.median(pos))) if len(pos) else 1.0
        if self.indirect is None:
            self.indirect = np.zeros(len(self.target))
        self.w_area = self.area / self.area.sum()
        self._s_dot_m = np.einsum("ij,ij->i", self.positions, self.normals)
        # (3, k) contiguous coordinate rows: the forward model works on (K, k) planes of
        # one component each (no (K, k, 3) temporaries, no einsum)
        self._pT = np.ascontiguousarray(self.positions.T)
        self._nT = np.ascontiguousarray(self.normals.T)
        self.log_target = np.log(self.target + self.eps_lux)
        self.stats.setdefault("visibility_rays", 0)
        self.stats.setdefault("visibility_reused", 0)
        self.stats.setdefault("evaluations", 0)
        self._vis_cache = {}

    #: visibility masks kept per problem (by exact luminaire position and normal): greedy
    #: selection, pruning and scoring ask again and again for luminaires that have not
    #: moved (each mask is k booleans, so 512 of 3000 points take 1.5 MB)
    VIS_CACHE_SIZE = 512

    # ------------------------------------------------------------------ forward model
    def visibility(self, light):
        """(k,) bool: which points see ``light`` (front-facing both ways, unoccluded).

        Masks are remembered by the luminaire's exact position and normal (bit for bit), so
        asking again for a luminaire that has not moved casts no rays; a returned mask is
        shared, read-only.
        """
        if self.bvh is None:
            return np.ones(len(self.positions), dtype=bool)
        key = (np.asarray(light.position, np.float64).tobytes(),
               np.asarray(light.facing(), np.float64).tobytes())
        vis = self._vis_cache.get(key)
        if vis is not None:
            self.stats["visibility_reused"] += 1
            return vis
        vis = self._visibility(light)
        vis.flags.writeable = False
        if len(self._vis_cache) >= self.VIS_CACHE_SIZE:
            self._vis_cache.pop(next(iter(self._vis_cache)))     # oldest first
        self._vis_cache[key] = vis
        return vis

    def _visibility(self, light):
        # an aimed luminaire sees what is in front of its mounting surface (its photometry
        # or cosine decides the rest), so its mask does not change with the aim
        facing = light.facing()
        d = light.position - self.positions
        front = (d @ facing < 0) & (np.einsum("ij,ij->i", d, self.normals) > 0)
        vis = np.zeros(len(self.positions), dtype=bool)
        idx = np.flatnonzero(front)
        if len(idx):
            p = self.positions[idx] + self.normals[idx] * C.RAY_EPS_M
            q = np.broadcast_to(light.position + facing * C.RAY_EPS_M, (len(idx), 3))
            fn = self.occluded_fn or (lambda a, b: segments_occluded_numpy(self.bvh, a, b))
            vis[idx] = ~fn(p, q)
            self.stats["visibility_rays"] += len(idx)
        return vis

    def light_of(self, light, vis, with_grad=False):
        """Illuminance (k,) of one luminaire at the points, and d E / d position (k, 3)
        (the one-luminaire case of :meth:`lights_of`)."""
        E, dE = self.lights_of([light], [vis], with_grad)
        return E[0], (None if dE is None else dE[0])

    def with_indirect(self, L):
        """L with its interreflected light attached (an estimate if it has none).

        The estimate is scaled by what exact solves have shown so far in this room (the
        flux-balance value is a mean over all surfaces; a work plane facing a bright ceiling
        gets more).
        """
        if L.indirect is None and self.indirect_estimate is not None:
            L = L.copy()
            L.indirect = self.indirect_estimate(L) * self._estimate_scale()
            L.indirect_grad = None
        return L

    def _estimate_scale(self):
        n = self.stats.get("indirect_calibrations", 0)
        return self.stats["indirect_ratio_sum"] / n if n else 1.0

    def refresh_indirect(self, lights, moved=0.05):
        """Exact interreflection for luminaires without it or moved more than ``moved`` m.

        Returns the lights and whether any was refreshed.
        """
        if self.indirect_exact is None:
            return lights, False
        out, changed = [], False
        for L in lights:
            if L.indirect_at is None or np.linalg.norm(L.position - L.indirect_at) > moved:
                L = L.copy()
                L.indirect = self.indirect_exact(L)
                L.indirect_at = L.position.copy()
                L.indirect_grad = (self.indirect_gradient_of(L) if self.indirect_gradient
                                   else None)
                changed = True
                if self.indirect_estimate is not None:
                    est = float(np.mean(self.indirect_estimate(L)))
                    if est > 0:
                        self.stats["indirect_ratio_sum"] = (
                            self.stats.get("indirect_ratio_sum", 0.0)
                            + float(np.mean(L.indirect)) / est)
                        self.stats["indirect_calibrations"] = (
                            self.stats.get("indirect_calibrations", 0) + 1)
            out.append(L)
        return out, changed

    def indirect_gradient_of(self, L, h=INDIRECT_GRAD_STEP_M):
        """(k, 3) d indirect / d position of ``L`` at the problem's flux (lux per metre):
        central differences of :attr:`indirect_exact` along the directions its position
        moves in (u and v on a surface, x, y and z mid-air)."""
        n = L._npos()
        dirs = L.dpos()[:n]
        G = np.zeros((len(self.target), 3))
        p = L.params()
        for j in range(n):
            q = p.copy()
            q[j] += h
            up = self.indirect_exact(L.with_params(q))
            q[j] -= 2 * h
            down = self.indirect_exact(L.with_params(q))
            G += np.outer((up - down) / (2 * h), dirs[j])
        return G

    def fixed_light(self, lights):
        """(k,) illuminance (direct + own indirect) of luminaires that stay put."""
        E = np.zeros(len(self.positions))
        for L in lights:
            E += self.light_of(L, self.visibility(L))[0]
            if L.indirect is not None:
                E += L.own_indirect()
        return E

    def _photometric(self, C, N, scale, M=None):
        """E (K, k) of luminaires at ``C`` facing ``N`` with the problem's distribution:
        E = F I(w)/F cos(theta_s) / r^2, w the unit direction luminaire -> point.
        ``M``: per luminaire its mount normal or None (aimed: the C = 0 axis turns with
        the tilt, :func:`invrad_wb.core.model.aiming.aimed_c0`)."""
        from invrad_wb.core.model.scene import plane_basis
        from invrad_wb.core.model.aiming import aimed_c0, photometric_frame
        out = np.zeros((len(C), len(self.positions)))
        for i, (c, n) in enumerate(zip(C, N)):
            if M is None or M[i] is None or self._symmetric():
                u, v = plane_basis(n)
            else:
                u, v = photometric_frame(n, aimed_c0(M[i], n))
            d = self.positions - c                                  # luminaire -> point
            r2 = np.maximum(np.einsum("ij,ij->i", d, d), 1e-12)
            w = d / np.sqrt(r2)[:, None]
            cs = -np.einsum("ij,ij->i", self.normals, w)
            i_lm = self.photometry.intensity_per_lm(np.stack([w @ u, w @ v, w @ n], axis=1))
            out[i] = np.where(cs > 1e-9, scale[i] * self.flux * i_lm * cs / r2, 0.0)
        return out

    def _beam(self):
        """The :class:`~invrad_wb.core.inverse.aimlight.SymmetricBeam` of the problem's
        distribution at its points (made once)."""
        beam = getattr(self, "_sym_beam", None)
        if beam is None:
            from invrad_wb.core.inverse.aimlight import SymmetricBeam
            beam = self._sym_beam = SymmetricBeam(self.photometry.table[0], self.positions,
                                                  self.normals)
        return beam

    def _symmetric(self):
        """Whether the distribution is rotationally symmetric (its frame's C = 0 axis
        does not matter)."""
        sym = getattr(self, "_sym", None)
        if sym is None:
            t = self.photometry.table
            sym = self._sym = bool(np.array_equal(t, np.broadcast_to(t[:1], t.shape)))
        return sym

    def _photometric_lights(self, C, N, scale, V, with_grad, M=None):
        if (M is not None or self.free_aim) and self._symmetric():
            # --aim free with a symmetric distribution: one batch (aimlight)
            return self._beam().lights(C, N, scale * self.flux, V, with_grad)
        E = np.where(V, self._photometric(C, N, scale, M), 0.0)
        if not with_grad:
            return E, None
        h = 1e-4
        dE = np.zeros(E.shape + (3,))
        for j in range(3):
            dc = np.zeros(3)
            dc[j] = h
            dE[..., j] = np.where(V, (self._photometric(C + dc, N, scale, M)
                                      - self._photometric(C - dc, N, scale, M)) / (2 * h),
                                  0.0)
        return E, dE

    def lights_of(self, lights, vis_list, with_grad=False):
        """All luminaires at once: E (K, k) and, with_grad, d E / d position (K, k, 3)."""
        if self.photometry is not None:
            C = np.array([L.position for L in lights])
            N = np.array([L.normal for L in lights])
            V = np.array(vis_list, dtype=bool).reshape(len(lights), -1)
            scale = np.array([L.flux_scale for L in lights])
            self.stats["evaluations"] += len(lights)
            M = [L.mount for L in lights]
            return self._photometric_lights(C, N, scale, V, with_grad,
                                            None if all(m is None for m in M) else M)
        st = self._lambertian(lights, vis_list)
        return st.E, (self._lambertian_grad(st) if with_grad else None)

    def _lambertian(self, lights, vis_list):
        """The lambertian forward model's :class:`_Direct`: E (K, k) and what its gradient
        needs."""
        C = np.array([L.position for L in lights], dtype=np.float64)   # (K, 3)
        N = np.array([L.normal for L in lights], dtype=np.float64)     # (K, 3)
        V = np.array(vis_list, dtype=bool).reshape(len(lights), -1)
        px, py, pz = self._pT
        # the sums and products below are those of
        #   A = -(dx N_x + dy N_y + dz N_z),  B = C . n - s . n,  r2 = dx^2 + dy^2 + dz^2,
        #   E = where(ok, s F / pi A B / r2^2, 0)
        # in the same order, into arrays made once per call (no temporaries)
        dx = C[:, 0:1] - px                                         # c - s, (K, k) each
        dy = C[:, 1:2] - py
        dz = C[:, 2:3] - pz
        t = np.empty_like(dx)
        A = np.multiply(dx, N[:, 0:1])
        A += np.multiply(dy, N[:, 1:2], out=t)
        A += np.multiply(dz, N[:, 2:3], out=t)
        np.negative(A, out=A)
        B = C @ self._nT
        B -= self._s_dot_m[None, :]
        r2 = np.multiply(dx, dx)
        r2 += np.multiply(dy, dy, out=t)
        r2 += np.multiply(dz, dz, out=t)
        ok = A > 1e-9
        ok &= B > 1e-9
        ok &= V
        # a point exactly at a luminaire (a voting point on a vertex where a wall light
        # sits) is not lit by it (A = 0): no 1 / 0 in the terms that are dropped
        off = ~ok
        np.copyto(A, 1.0, where=off)
        np.copyto(B, 1.0, where=off)
        np.copyto(r2, 1.0, where=off)
        scale = np.array([L.flux_scale for L in lights])[:, None]
        E = np.multiply(scale * (self.flux / np.pi), A)
        E *= B
        E /= np.multiply(r2, r2, out=t)
        np.copyto(E, 0.0, where=off)
        self.stats["evaluations"] += len(lights)
        return _Direct(E, N, dx, dy, dz, A, B, r2, t)

    def _lambertian_grad(self, st):
        """d E / d position (K, k, 3; a (k, K, 3) array's view, the Jacobian's layout) of a
        :class:`_Direct` (its A, B, r2 and scratch overwritten: one gradient per state)."""
        E, N, t = st.E, st.N, st.t
        # d E / d c = E (-N / A + n / B - 4 (c - s) / r^2), one component at a time
        iA, iB, ir2 = np.divide(1.0, st.A, out=st.A), np.divide(1.0, st.B, out=st.B), \
            np.divide(-4.0, st.r2, out=st.r2)
        dE = np.empty((E.shape[1], E.shape[0], 3)).transpose(1, 0, 2)
        u = np.empty_like(E)
        for j, (dj, nj) in enumerate(((st.dx, self._nT[0]), (st.dy, self._nT[1]),
                                      (st.dz, self._nT[2]))):
            np.multiply(iB, nj, out=u)
            u -= np.multiply(N[:, j:j + 1], iA, out=t)
            u += np.multiply(dj, ir2, out=t)
            np.multiply(E, u, out=dE[..., j])
        return dE

    def residuals(self, lights, vis_list, with_jac=False, extra=None, memo=None):
        """Residuals r (k,) and, with_jac, their Jacobian (k, n) of ``lights``.

        ``memo``: a dict kept by the caller across calls. A call without the Jacobian
        leaves its model there; a call with it for the same luminaires (position, normal,
        flux and own indirect light bit for bit) with the same visibility (equal masks) and
        the same ``extra`` takes E and r from it and computes only the derivatives: the
        optimiser asks for the Jacobian at every trial point it accepts, right after the
        trial's residuals (the same numbers; in the office example 370 of the 405 Jacobian
        calls)."""
        key = None
        if memo is not None and lights and self.photometry is None:
            # what the model reads of each luminaire: position, normal, flux, own indirect
            key = tuple((L.position.tobytes(), L.normal.tobytes(), L.flux_scale)
                        for L in lights)
            got = memo.pop("trial", None)
            if (with_jac and got is not None and got[0] == key
                    and len(got[1]) == len(vis_list)
                    and all(a is b or np.array_equal(a, b)
                            for a, b in zip(got[1], vis_list))
                    and all(a is L.indirect for a, L in zip(got[2], lights))
                    and got[3] is extra):
                r, Ep, st = got[4], got[5], got[6]
                return r, self._jacobian(lights, vis_list, st.E,
                                         self._lambertian_grad(st), Ep)
        E = self.indirect.copy() if extra is None else self.indirect + extra
        e = de = st = None
        if lights:
            if key is not None:
                st = self._lambertian(lights, vis_list)
                e = st.E
                if with_jac:
                    de = self._lambertian_grad(st)
            else:
                e, de = self.lights_of(lights, vis_list, with_jac)
            # one luminaire: its row as it is (a sum over one row is that row)
            E += e[0] if len(e) == 1 else e.sum(axis=0)
            for L in lights:
                # at the problem's flux its own indirect light as it is (1.0 x is x)
                own = (L.indirect if L.flux_scale == 1.0 and L.indirect_grad is None
                       else L.own_indirect())
                if own is not None:
                    E += own
        Ep = np.add(E, self.eps_lux, out=E)         # E is this call's own
        r = np.log(Ep) - self.log_target
        if not with_jac:
            if key is not None:
                memo["trial"] = (key, list(vis_list), [L.indirect for L in lights], extra,
                                 r, Ep, st)
            return r, None
        if not lights:
            return r, np.zeros((len(r), 0))
        return r, self._jacobian(lights, vis_list, e, de, Ep)

    def _jacobian(self, lights, vis_list, e, de, Ep):
        """(k, n) d r / d parameters from each luminaire's light e (K, k), its position
        derivatives de (K, k, 3) and the predicted light plus eps, Ep (k,)."""
        if all(L.kind == "free" and not L.free_aim and not L.free_flux
               and L.indirect_grad is None for L in lights):
            J = de.transpose(1, 0, 2)       # + 0.0: the product with dpos() = I, bit for bit
            J = np.add(J, 0.0, out=J if J.flags.c_contiguous else np.empty(J.shape))
            return optim.divide_rows(J.reshape(len(Ep), -1), Ep)
        jac_blocks = []
        for i, L in enumerate(lights):
            own = (L.indirect if L.flux_scale == 1.0 and L.indirect_grad is None
                   else L.own_indirect())
            block = de[i] @ L.dpos().T
            if own is not None and L.indirect_grad is not None and L.indirect_at is not None:
                block += (L.flux_scale * L.indirect_grad) @ L.dpos().T
            if L.free_aim:
                n = L._npos()
                block[:, n:n + 2] = self._aim_jacobian(L, vis_list[i])
            if L.free_flux:
                # d E / d ln(scale): the luminaire's whole light, direct + indirect
                block[:, -1] = e[i] if own is None else e[i] + own
            jac_blocks.append(block)
        J = jac_blocks[0] if len(jac_blocks) == 1 else np.concatenate(jac_blocks, axis=1)
        # divided in place (the blocks are this call's own arrays)
        return optim.divide_rows(J, Ep)

    def _aim_jacobian(self, L, vis, h=1e-4):
        """(k, 2) d E / d aim coordinates of one aimable luminaire (central differences)."""
        n = L._npos()
        if self.photometry is not None and self._symmetric():
            # the aim coordinates alone, as L.params()[n:n + 2] has them
            from invrad_wb.core.model.aiming import aim_offset, max_offset
            ab = aim_offset(L.mount, L.normal)
            if np.hypot(ab[0], ab[1]) < max_offset(L.max_tilt) - 2 * h:   # not clamped
                from invrad_wb.core.model.aiming import aim_of_offset_jacobian
                g = self._beam().aim_grad(L.position, L.normal, L.flux_scale * self.flux,
                                          aim_of_offset_jacobian(L.mount, ab))
                return np.where(np.asarray(vis, dtype=bool).reshape(-1)[:, None], g, 0.0)
        p = L.params()
        moved = []
        for j in range(2):
            for sign in (1.0, -1.0):
                q = p.copy()
                q[n + j] += sign * h
                moved.append(L.with_params(q))
        E = self.lights_of(moved, [vis] * 4)[0]                 # the four in one call
        return np.stack([(E[0] - E[1]) / (2 * h), (E[2] - E[3]) / (2 * h)], axis=1)

    def cost_of(self, r):
        c, got = self.robust_scale, getattr(self, "_wcc", None)     # w_area c^2, kept
        if got is None or got[0] != c or got[1] is not self.w_area:
            got = self._wcc = (c, self.w_area, self.w_area * c * c)
        return optim.pseudo_huber(r, c, got[2])

    def cost(self, lights, vis_list=None, extra=None):
        if vis_list is None:
            vis_list = [self.visibility(L) for L in lights]
        r, _ = self.residuals(lights, vis_list, extra=extra)
        return self.cost_of(r) + self.separation_cost(lights)

    # ------------------------------------------------------------------ separation
    #: luminaires facing the same way closer than this are pushed apart (metres); real
    #: fixtures are separate objects, and without it the fit can let two or three
    #: overlapping luminaires collapse into one spot with their summed flux
    separation_m = 0.3

    def _separation_weight(self):
        w = getattr(self, "_sep_w", None)
        if w is None:
            r, _ = self.residuals([], [])
            w = self._sep_w = float(np.sqrt(0.01 * self.cost_of(r)))
        return w

    def separation(self, lights, with_jac=False):
        """Penalty residuals (p,) for close pairs and, with_jac, their Jacobian (p, n)."""
        if len(lights) < 2:           # no pair (every optimiser step of one luminaire)
            return np.zeros(0), (np.zeros((0, sum(L.n_params() for L in lights)))
                                 if with_jac else None)
        rows, jac = [], []
        lam, d0 = self._separation_weight(), self.separation_m
        # only pairs closer than d0 count: found with one distance matrix (a Python loop
        # over every pair was a sixth of a dozen luminaires' optimiser time); a few
        # luminaires' pairs by plain floats (the matrix's dozen numpy calls cost more
        # there). Either is only a pre-selection: each pair is measured again below.
        lim = d0 * d0 * (1 + 1e-9)
        if len(lights) <= 6:
            P = [L.position.tolist() for L in lights]
            near = [(i, j) for i in range(len(P)) for j in range(i + 1, len(P))
                    if (P[i][0] - P[j][0]) ** 2 + (P[i][1] - P[j][1]) ** 2
                    + (P[i][2] - P[j][2]) ** 2 < lim]
        else:
            P = np.array([L.position for L in lights]).reshape(-1, 3)
            near = np.argwhere(np.triu(np.sum((P[:, None] - P[None]) ** 2, axis=2) < lim,
                                       k=1))
        starts = None
        for i, j in near:
            a, b = lights[i], lights[j]
            if a.facing() @ b.facing() < 0.5:
                continue
            diff = a.position - b.position
            d = float(np.linalg.norm(diff))
            if d >= d0:
                continue
            if starts is None:
                sizes = [L.n_params() for L in lights]
                starts = np.concatenate([[0], np.cumsum(sizes)]).astype(int)
            rows.append(lam * (1.0 - d / d0))
            if with_jac:
                e = diff / d if d > 1e-9 else a.dpos()[0] / np.linalg.norm(a.dpos()[0])
                row = np.zeros(starts[-1])
                row[starts[i]:starts[i + 1]] = -lam / d0 * (a.dpos() @ e)
                row[starts[j]:starts[j + 1]] = lam / d0 * (b.dpos() @ e)
                jac.append(row)
        r = np.array(rows)
        if not with_jac:
            return r, None
        if not jac:
            return r, np.zeros((0, sum(L.n_params() for L in lights)))
        return r, np.array(jac)

    def separation_cost(self, lights):
        if len(lights) < 2:
            return 0.0
        r, _ = self.separation(lights)
        return float(np.sum(r * r))

    # ------------------------------------------------------------------ optimisers
    def _own_copies(self, lights):
        """Copies of ``lights`` whose parameters are those this problem fits."""
        out = [L.copy() for L in lights]
        for L in out:
            L.free_flux = self.free_flux
            L.free_aim = self.free_aim and L.mount is not None
        return out

    def _packing(self, lights):
        """(x0 (n,), unpack(x) -> lights) for a joint fit of ``lights``' parameters."""
        x0 = np.concatenate([L.params() for L in lights])
        ends = np.cumsum([L.n_params() for L in lights]).tolist()
        parts = list(zip(lights, [0] + ends[:-1], ends))

        def unpack(x):
            # slices, as np.split gives them (np.split's own work was a tenth of unpacking)
            return [L.with_params(x[a:b]) for L, a, b in parts]
        return x0, unpack

    def levenberg_marquardt(self, lights, iterations=25, tol=1e-7, fixed=None):
        """Jointly refine all positions; returns (lights, cost).

        :func:`invrad_wb.core.inverse.optim.levenberg_marquardt` on the residuals
        (IRLS weights of the pseudo-Huber cost, the separation term as quadratic rows),
        with the analytic Jacobian; a luminaire whose step would leave its faces or room
        (:attr:`inside`) keeps its place; visibility is refreshed where a luminaire moved
        more than 2 cm after a step. At most ``iterations`` steps are taken, each after at
        most 8 trials (damping x10 per failed trial).

        ``fixed``: (k,) illuminance of other luminaires that do not move (optional).
        """
        lights = self._own_copies(lights)
        if not lights:
            return lights, self.cost([], extra=fixed)
        x0, unpack = self._packing(lights)
        k, c = len(self.positions), self.robust_scale
        pairs = len(lights) * (len(lights) - 1) // 2
        vis = [self.visibility(L) for L in lights]
        vis_at = [L.position.copy() for L in lights]
        memo = {}       # the latest trial's model: its Jacobian call, once accepted, reuses it

        def fun(x, _idx, jac):
            new = unpack(x[0])
            if jac:
                for i, L in enumerate(new):
                    if np.linalg.norm(L.position - vis_at[i]) > 0.02:
                        vis[i] = self.visibility(L)
                        vis_at[i] = L.position.copy()
            r, J = self.residuals(new, vis, jac, extra=fixed, memo=memo)
            if not pairs:
                # one luminaire: no separation rows (views of the arrays, no copies)
                return r[None] if not jac else (r[None], J[None])
            rp, Jp = self.separation(new, jac)
            # one row per pair (zero where apart): the batch needs a fixed row count
            r = np.concatenate([r, rp, np.zeros(pairs - len(rp))])[None]
            if not jac:
                return r
            return r, np.concatenate([J, Jp, np.zeros((pairs - len(rp), len(x0)))])[None]

        def cost(r):
            if not pairs:       # the same sum: + 0.0 (no separation rows) adds nothing
                return np.array([self.cost_of(r[0])])
            return np.array([self.cost_of(r[0, :k]) + float(r[0, k:] @ r[0, k:])])

        def weights(r):
            if not pairs:
                return optim.pseudo_huber_weights(r[0], c, self.w_area)[None]
            w = np.ones_like(r)
            optim.pseudo_huber_weights(r[0, :k], c, self.w_area, out=w[0, :k])
            return w

        def project(x_old, x_new, _idx):
            # per luminaire: one that would leave its plane/room keeps its place (the old
            # ones unpacked only then: most steps leave every luminaire inside)
            moved = [self.inside(M) for M in unpack(x_new[0])]
            if any(M is None for M in moved):
                moved = [L if M is None else M for L, M in zip(unpack(x_old[0]), moved)]
            return np.concatenate([L.params() for L in moved])[None]

        def step(J, r, lam):
            return optim.dense_step(J, r, lam, weights(r), ridge=0.0)
        project = None if self.inside is None else project
        if self.free_flux:              # luminaires of one kind share a flux (tiedparams)
            x0, step, project = tied_fit(lights, x0, step, project)
        res = optim.levenberg_marquardt(
            fun, x0[None], cost=cost, step=step, project=project, max_iter=None,
            max_steps=iterations, max_tries=8, ftol=tol, xtol=1e-5, lam_up=10.0,
            lam_min=1e-9, lam_max=np.inf)
        return unpack(res.x[0]), float(res.cost[0])

    def evolution_strategy(self, lights, iterations=400, sigma=0.1, seed=0, fixed=None):
        """The thesis' (1+1) evolution strategy (:func:`invrad_wb.core.inverse.optim.
        evolution_strategy`, 1/5 rule every 20 generations) for at most ``iterations``
        generations; visibility is refreshed at each step-size adaptation."""
        lights = self._own_copies(lights)
        if not lights:
            return lights, self.cost([], extra=fixed)
        x0, unpack = self._packing(lights)
        vis = [self.visibility(L) for L in lights]

        def project(X):
            # its lights moved into the allowed region (:attr:`inside`); NaN (an
            # infinite cost) where a luminaire cannot be placed there
            if self.inside is None:
                return X
            moved = [self.inside(L) for L in unpack(X[0])]
            if any(L is None for L in moved):
                return np.full_like(X, np.nan)
            return np.concatenate([L.params() for L in moved])[None]

        def cost(X):
            if not np.all(np.isfinite(X)):
                return np.array([np.inf])
            return np.array([self.cost(unpack(X[0]), vis, extra=fixed)])

        def refresh(X):
            vis[:] = [self.visibility(L) for L in unpack(X[0])]
            return cost(X)

        res = optim.evolution_strategy(cost, x0[None], sigma, rng=seed,
                                       max_generations=iterations, adapt_every=20, xtol=1e-4,
                                       project=project, refresh=refresh)
        return unpack(res.x[0]), float(res.cost[0])
