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
        for b in range(0, len(C), step):
            sl = slice(b, b + step)
            d = self.points[None] - C[sl, None]                     # luminaire -> point
            r2 = np.maximum(np.einsum("Kkj,Kkj->Kk", d, d), 1e-12)
            inv = 1.0 / np.sqrt(r2)
            w = d * inv[..., None]
            cs = -np.einsum("kj,Kkj->Kk", self.normals, w)
            cg = np.clip(np.einsum("Kkj,Kj->Kk", w, N[sl]), -1.0, 1.0)
            g = np.degrees(np.arccos(cg)) / STEP_DEG
            i0 = np.minimum(g.astype(np.int64), len(curve) - 2)
            slope = curve[i0 + 1] - curve[i0]                      # per table step
            i_lm = curve[i0] + (g - i0) * slope
            lit = cs > 1e-9
            f = np.where(lit, flux[sl, None] / r2, 0.0)
            out[sl] = f * i_lm * cs
            if with_grad:
                sin_g = np.sqrt(np.maximum(1.0 - cg * cg, 0.0))
                dg = np.where(sin_g > 1e-12, slope * (np.degrees(1.0) / STEP_DEG)
                              * cs / np.maximum(sin_g, 1e-12), 0.0)     # I' cos_s / sin_g
                t = (dg[..., None] * (N[sl, None] - cg[..., None] * w)
                     + i_lm[..., None] * (self.normals[None] + 3.0 * cs[..., None] * w))
                grad[sl] = (f * inv)[..., None] * t
        return (out, grad) if with_grad else out

    def aim_grad(self, c, n, flux, dn):
        """(k, m) d E / d p of one luminaire at ``c`` aimed ``n`` whose aim moves with m
        parameters p as ``dn`` (m, 3) = d n / d p: ``dE/dp = -F cos_s I' / (r^2 sin_g)
        (w . dn/dp)`` (0 on the axis)."""
        d = self.points - np.asarray(c, dtype=np.float64)
        r2 = np.maximum(np.einsum("kj,kj->k", d, d), 1e-12)
        w = d / np.sqrt(r2)[:, None]
        cs = -np.einsum("kj,kj->k", self.normals, w)
        cg = np.clip(w @ n, -1.0, 1.0)
        g = np.degrees(np.arccos(cg)) / STEP_DEG
        i0 = np.minimum(g.astype(np.int64), len(self.curve) - 2)
        slope = (self.curve[i0 + 1] - self.curve[i0]) * (np.degrees(1.0) / STEP_DEG)
        sin_g = np.sqrt(np.maximum(1.0 - cg * cg, 0.0))
        k = np.where((cs > 1e-9) & (sin_g > 1e-12),
                     -flux * cs * slope / (r2 * np.maximum(sin_g, 1e-12)), 0.0)
        return k[:, None] * (w @ np.asarray(dn, dtype=np.float64).T)

    def lights(self, C, N, flux, V, with_grad):
        """E (K, k) where visible (``V`` (K, k) bool) and, ``with_grad``, d E / d position
        (K, k, 3)."""
        if not with_grad:
            return np.where(V, self.light(C, N, flux), 0.0), None
        E, dE = self.light(C, N, flux, with_grad=True)
        return np.where(V, E, 0.0), np.where(V[..., None], dE, 0.0)
