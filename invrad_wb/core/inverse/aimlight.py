"""The refinement's light of aimable luminaires with a rotationally symmetric distribution
(``locate --aim free``), many luminaires and finite-difference neighbours in one batch.

The refinement evaluates a luminaire's light at its position and at six neighbours (the
position gradient by central differences), and an aimed one at four more (the aim's).
With a distribution that does not depend on the C angle the frame of each luminaire does
not matter: the intensity is a curve of gamma alone, ``I(gamma) = table[0]`` (the same
values the bilinear lookup of :meth:`~invrad_wb.core.model.photometry.Photometry.
intensity_per_lm` gives on such a table, without its per-luminaire frames and C
interpolation). Profiled on bench_aim's gallery (2-core machine, load 9): the per-luminaire
path spent 104 s of 158 in ``_photometric`` (frames 31 s, bilinear lookup 52 s).
"""
import numpy as np

from invrad_wb.core.model.photometry import STEP_DEG

#: luminaires per batch at most (memory: batch x points x 3 float64)
BATCH_POINTS = 2_000_000


class SymmetricBeam:
    """Direct light at fixed receivers of luminaires with one rotationally symmetric
    intensity distribution.

    Parameters
    ----------
    curve : (181,) float64, cd/lm at gamma 0..180 degrees (``STEP_DEG`` apart)
    points, normals : (k, 3) float64, receivers (metres, unit normals)
    """

    def __init__(self, curve, points, normals):
        self.curve = np.asarray(curve, dtype=np.float64)
        self.gamma = np.arange(len(self.curve)) * STEP_DEG
        self.points = np.asarray(points, dtype=np.float64)
        self.normals = np.asarray(normals, dtype=np.float64)
        # (3, k) contiguous coordinate rows: (K, k) planes of one component each, no
        # (K, k, 3) temporaries or einsum (the refinement's light was half its time)
        self._pT = np.ascontiguousarray(self.points.T)
        self._nT = np.ascontiguousarray(self.normals.T)
        #: the last gradient batch's per-luminaire terms of the aim gradient, by exact
        #: position and aim (:meth:`aim_grad` asks right after :meth:`light`)
        self._aim_terms = {}

    def light(self, C, N, flux, with_grad=False):
        """(K, k) lux of K luminaires at ``C`` (K, 3) aimed ``N`` (K, 3, unit) with fluxes
        ``flux`` (K,) lm: ``F I(gamma) cos(theta_s) / r^2`` where the receiver faces it;
        ``with_grad``: and d E / d position (K, k, 3), analytic (``I`` piecewise linear in
        gamma, as the table is read)::

            dE/dc = F / r^2 [I' cos_s (n - cos_g w) / (r sin_g)
                             + I (n_p + cos_s w) / r + 2 I cos_s w / r]

        (``w`` the unit direction luminaire -> point, ``n_p`` the receiver's normal; the
        first term is 0 on the axis, where the direction of d gamma is undefined)."""
        C = np.asarray(C, dtype=np.float64).reshape(-1, 3)
        N = np.asarray(N, dtype=np.float64).reshape(-1, 3)
        flux = np.broadcast_to(np.asarray(flux, dtype=np.float64), (len(C),))
        out = np.empty((len(C), len(self.points)))
        grad = np.empty((len(C), len(self.points), 3)) if with_grad else None
        step = max(1, BATCH_POINTS // max(1, len(self.points)))
        curve = self.curve
        to_step = np.degrees(1.0) / STEP_DEG
        px, py, pz = self._pT
        nx, ny, nz = self._nT
        if with_grad:
            self._aim_terms = {}
        for b in range(0, len(C), step):
            sl = slice(b, b + step)
            c, a = C[sl], N[sl]
            dx = px - c[:, 0:1]                                    # luminaire -> point
            dy = py - c[:, 1:2]
            dz = pz - c[:, 2:3]
            r2 = np.maximum(dx * dx + dy * dy + dz * dz, 1e-12)
            inv = 1.0 / np.sqrt(r2)
            cs = -(nx * dx + ny * dy + nz * dz) * inv
            cg = np.clip((a[:, 0:1] * dx + a[:, 1:2] * dy + a[:, 2:3] * dz) * inv, -1.0, 1.0)
            g = np.arccos(cg) * (to_step)
            i0 = np.minimum(g.astype(np.int64), len(curve) - 2)
            c0 = curve[i0]
            slope = curve[i0 + 1] - c0                             # per table step
            i_lm = c0 + (g - i0) * slope
            lit = cs > 1e-9
            f = np.where(lit, flux[sl, None] / r2, 0.0)
            out[sl] = f * i_lm * cs
            if with_grad:
                sin_g = np.sqrt(np.maximum(1.0 - cg * cg, 0.0))
                on = sin_g > 1e-12
                dg = np.where(on, slope * to_step * cs / np.where(on, sin_g, 1.0), 0.0)
                fi = f * inv
                # I' cos_s / sin_g (n - cos_g w) + I (n_p + 3 cos_s w), times F / r^3
                t1 = fi * dg
                t2 = fi * i_lm
                tw = t2 * 3.0 * cs - t1 * cg
                for j, (dj, nj) in enumerate(((dx, nx), (dy, ny), (dz, nz))):
                    grad[sl, :, j] = t1 * a[:, j:j + 1] + t2 * nj + tw * (dj * inv)
                # d E / d aim = -F cos_s I' / (r^2 sin_g) (w . d n / d p) (0 on the axis)
                q = -np.where(lit, dg * inv, 0.0) * inv      # per lumen, times w . dn
                for i in range(len(c)):
                    key = (c[i].tobytes(), a[i].tobytes())
                    self._aim_terms[key] = (q[i], dx[i] * inv[i], dy[i] * inv[i],
                                            dz[i] * inv[i])
        return (out, grad) if with_grad else out

    def aim_grad(self, c, n, flux, dn):
        """(k, m) d E / d p of one luminaire at ``c`` aimed ``n`` whose aim moves with m
        parameters p as ``dn`` (m, 3) = d n / d p: ``dE/dp = -F cos_s I' / (r^2 sin_g)
        (w . dn/dp)`` (0 on the axis). Taken from the last gradient batch of
        :meth:`light` where it held this luminaire (the refinement asks right after)."""
        c = np.asarray(c, dtype=np.float64)
        n = np.asarray(n, dtype=np.float64)
        dn = np.asarray(dn, dtype=np.float64)
        terms = self._aim_terms.get((c.tobytes(), n.tobytes()))
        if terms is None:
            self.light(c[None], n[None], 1.0, with_grad=True)
            terms = self._aim_terms[(c.tobytes(), n.tobytes())]
        q, wx, wy, wz = terms
        k = flux * q
        return np.stack([k * (wx * m[0] + wy * m[1] + wz * m[2]) for m in dn], axis=1)

    def lights(self, C, N, flux, V, with_grad):
        """E (K, k) where visible (``V`` (K, k) bool) and, ``with_grad``, d E / d position
        (K, k, 3)."""
        if not with_grad:
            return np.where(V, self.light(C, N, flux), 0.0), None
        E, dE = self.light(C, N, flux, with_grad=True)
        return np.where(V, E, 0.0), np.where(V[..., None], dE, 0.0)
