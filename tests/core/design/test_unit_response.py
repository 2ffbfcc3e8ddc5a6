"""The fast model's direct light of a lambertian disk (evaluate.unit_response): the full
disk rule near it, a 6-point ring at receivers far from it (DISK_FAR_RADII). Checked
against the disk's analytic configuration factor and a brute-force integration."""
import numpy as np
import pytest

from invrad_wb.core.design import evaluate as ev
from invrad_wb.core.model.luminaires import disk_quadrature

R = 0.3          # a 600 mm round panel


def parallel_disk(h, a, r=R):
    """lux per lumen of a lambertian disk (radius r, flux 1 lm) at a receiver facing it on a
    parallel plane h below, a from its axis: the configuration factor of a disk to a
    parallel element (Howell's catalogue, B-13) x M / pi r^2 ... per lumen: F / (pi r^2)."""
    a = np.maximum(a, 1e-9)
    H, Rr = h / a, r / a
    Z = 1.0 + H * H + Rr * Rr
    F = 0.5 * (1.0 - (Z - 2.0 * Rr * Rr) / np.sqrt(Z * Z - 4.0 * Rr * Rr))
    return F / (np.pi * r * r)


def brute_force(points, normals, centre, n, r=R):
    """lux per lumen by a 40 x 96 disk rule, written out independently."""
    qp, qw = disk_quadrature(40, 96)
    u = np.cross(n, [0.0, 1.0, 0.0] if abs(n[1]) < 0.9 else [1.0, 0.0, 0.0])
    u /= np.linalg.norm(u)
    v = np.cross(n, u)
    out = np.zeros(len(points))
    for q, w in zip(r * qp, qw):
        d = points - (centre + q[0] * u + q[1] * v)
        dist = np.linalg.norm(d, axis=1)
        cos_e = np.maximum(d @ n, 0.0) / dist
        cos_r = np.maximum(-np.sum(normals * d, axis=1), 0.0) / dist
        out += w * cos_e * cos_r / (np.pi * dist ** 2)
    return out


def test_disk_on_a_parallel_plane_matches_the_analytic_factor_near_and_far():
    h, a = np.meshgrid([0.5, 0.8, 1.2, 1.7, 2.2, 3.0], np.linspace(0.0, 4.0, 41))
    h, a = h.ravel(), a.ravel()
    pts = np.stack([a, np.zeros_like(a), -h], axis=1)
    far = np.hypot(h, a) >= ev.DISK_FAR_RADII * R
    assert far.any() and (~far).any()           # both rules are exercised
    e = ev.unit_response(pts, np.tile([0.0, 0.0, 1.0], (len(a), 1)), np.zeros((1, 3)),
                         np.array([[0.0, 0.0, -1.0]]), R)[:, 0]
    ref = parallel_disk(h, a)
    assert np.abs(e / ref - 1.0).max() < 1e-3


@pytest.mark.parametrize("tilt", [0.0, 0.6])
def test_disk_at_any_receiver_clear_of_it_matches_a_brute_force_integral(tilt):
    rng = np.random.default_rng(7)
    n = np.array([np.sin(tilt), 0.0, -np.cos(tilt)])
    centre = np.array([1.0, 2.0, 2.7])
    d = rng.normal(size=(4000, 3))
    d /= np.linalg.norm(d, axis=1)[:, None]
    d[d @ n < 0.05] *= -1.0                                  # in front of the disk
    pts = centre + rng.uniform(2.0, 20.0, (4000, 1)) * R * d
    nrm = rng.normal(size=(4000, 3))
    nrm /= np.linalg.norm(nrm, axis=1)[:, None]
    # the receiver's plane keeps clear of the disk (no horizon across it)
    keep = (np.abs(np.sum((centre - pts) * nrm, axis=1)) > R) & (d @ n > 0.05)
    pts, nrm = pts[keep], nrm[keep]
    e = ev.unit_response(pts, nrm, centre[None], n[None], R)[:, 0]
    ref = brute_force(pts, nrm, centre, n)
    lit = ref > 0
    far = np.linalg.norm(pts - centre, axis=1) >= ev.DISK_FAR_RADII * R
    assert far[lit].sum() > 1000 and (~far[lit]).sum() > 100
    rel = np.abs(e[lit] / ref[lit] - 1.0)
    assert rel[far[lit]].max() < 2e-3
    # near: the full 3 x 8 rule, as before (its own error, 1 % at 2 radii)
    assert rel[~far[lit]].max() < 2e-2
    assert np.array_equal(e[~lit], np.zeros((~lit).sum()))


def test_nothing_reaches_receivers_on_or_behind_the_disks_plane():
    rng = np.random.default_rng(3)
    centre, n = np.array([2.0, 1.5, 2.7]), np.array([0.0, 0.0, -1.0])
    ceiling = np.c_[rng.uniform(0, 4, 500), rng.uniform(0, 3, 500), np.full(500, 2.7)]
    above = ceiling + [0.0, 0.0, 0.4]
    pts = np.concatenate([ceiling, above])
    for nrm in ([0.0, 0.0, -1.0], [1.0, 0.0, 0.0]):
        e = ev.unit_response(pts, np.tile(nrm, (len(pts), 1)), centre[None], n[None], R)
        assert not e.any()
