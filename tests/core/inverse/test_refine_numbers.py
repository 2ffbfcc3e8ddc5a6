"""The optimiser's forward model and residuals (inverse/refine.py) computed without
temporaries give the numbers, bit for bit, of the plain expressions they replaced, and the
Jacobian is the residuals' derivative."""
import numpy as np

from invrad_wb.core.inverse.refine import Light, RefineProblem


def _problem(seed=0):
    rng = np.random.default_rng(seed)
    k = 300
    pts = np.c_[rng.uniform(0, 4, k), rng.uniform(0, 3, k), np.zeros(k)]
    pts[:40, 2] = 2.5                       # some points on the ceiling: not lit
    nrm = np.tile([0.0, 0.0, 1.0], (k, 1))
    nrm[:40] = [0.0, 0.0, -1.0]
    nrm[40:60] = [0.6, 0.0, 0.8]            # tilted receivers
    prob = RefineProblem(positions=pts, normals=nrm, target=rng.uniform(50, 400, k),
                         flux=2000.0, area=rng.uniform(0.5, 1.5, k))
    return prob, rng


def _lights(rng, k):
    o = np.array([0.0, 0.0, 2.5])
    out = []
    for i, (x, y) in enumerate([(1.0, 1.0), (3.0, 2.0), (2.0, 0.5)]):
        L = Light("surface", np.array([x, y, 2.5]), np.array([-0.0, -0.0, -1.0]), 0,
                  origin=o, u=np.array([1.0, 0.0, 0.0]), v=np.array([0.0, 1.0, 0.0]),
                  indirect=rng.uniform(0, 30, k))
        L.flux_scale = (1.0, 1.3, 0.8)[i]
        out.append(L)
    out[2].normal = np.array([0.1, 0.0, -1.0]) / np.hypot(0.1, 1.0)
    out.append(Light("free", np.array([2.5, 1.5, 1.7]), np.array([0.0, 0.0, -1.0]), 1))
    return out


def _reference(prob, lights, vis):
    """lights_of's expressions before they were written into reused arrays."""
    C = np.array([L.position for L in lights])
    N = np.array([L.normal for L in lights])
    V = np.array(vis, dtype=bool).reshape(len(lights), -1)
    px, py, pz = prob._pT
    dx, dy, dz = C[:, 0:1] - px, C[:, 1:2] - py, C[:, 2:3] - pz
    A = -(dx * N[:, 0:1] + dy * N[:, 1:2] + dz * N[:, 2:3])
    B = C @ prob._nT - prob._s_dot_m[None, :]
    r2 = dx * dx + dy * dy + dz * dz
    ok = (A > 1e-9) & (B > 1e-9) & V
    Ac, Bc, r2 = np.where(ok, A, 1.0), np.where(ok, B, 1.0), np.where(ok, r2, 1.0)
    scale = np.array([L.flux_scale for L in lights])[:, None]
    E = np.where(ok, (scale * (prob.flux / np.pi)) * Ac * Bc / (r2 * r2), 0.0)
    iA, iB, ir2 = 1.0 / Ac, 1.0 / Bc, -4.0 / r2
    dE = np.empty(E.shape + (3,))
    for j, (dj, nj) in enumerate(((dx, prob._nT[0]), (dy, prob._nT[1]), (dz, prob._nT[2]))):
        dE[..., j] = E * (iB * nj - N[:, j:j + 1] * iA + dj * ir2)
    return E, dE


def test_lights_of_gives_the_plain_expressions_numbers():
    prob, rng = _problem()
    lights = _lights(rng, len(prob.positions))
    vis = [rng.uniform(size=len(prob.positions)) > 0.2 for _ in lights]
    for sub in (lights[:1], lights[1:3], lights):
        v = vis[:len(sub)]
        want_E, want_dE = _reference(prob, sub, v)
        E, _ = prob.lights_of(sub, v)
        E2, dE = prob.lights_of(sub, v, with_grad=True)
        assert np.array_equal(E, want_E) and np.array_equal(E2, want_E)
        assert np.array_equal(dE, want_dE)
        assert (E > 0).any() and (E == 0).any()


def test_residuals_jacobian_is_their_derivative():
    prob, rng = _problem(1)
    lights = _lights(rng, len(prob.positions))[:3]
    for L in lights:
        L.free_flux = True
    vis = [np.ones(len(prob.positions), bool)] * len(lights)
    r, J = prob.residuals(lights, vis, with_jac=True)
    r1, _ = prob.residuals(lights[:1], vis[:1])
    assert np.array_equal(r, prob.residuals(lights, vis)[0])
    x = np.concatenate([L.params() for L in lights])
    sizes = np.cumsum([0] + [L.n_params() for L in lights])
    h = 1e-6
    for j in range(len(x)):
        moved = []
        for sgn in (1.0, -1.0):
            y = x.copy()
            y[j] += sgn * h
            moved.append([L.with_params(y[a:b]) for L, a, b in
                          zip(lights, sizes[:-1], sizes[1:])])
        num = (prob.residuals(moved[0], vis)[0] - prob.residuals(moved[1], vis)[0]) / (2 * h)
        np.testing.assert_allclose(J[:, j], num, rtol=1e-5, atol=1e-7)
    # one luminaire: its single Jacobian block, the same numbers as in a joint call's first
    _, J1 = prob.residuals(lights[:1], vis[:1], with_jac=True)
    assert J1.shape == (len(r1), lights[0].n_params())


def _pairs_reference(prob, lights):
    """Every close pair facing alike, one by one: lam (1 - d / d0)."""
    lam, d0 = prob._separation_weight(), prob.separation_m
    rows = []
    for i in range(len(lights)):
        for j in range(i + 1, len(lights)):
            a, b = lights[i], lights[j]
            d = float(np.linalg.norm(a.position - b.position))
            if a.facing() @ b.facing() >= 0.5 and d < d0:
                rows.append(lam * (1.0 - d / d0))
    return np.array(rows)


def test_separation_rows_are_every_close_pair_few_or_many():
    prob, rng = _problem(2)
    for n in (2, 3, 6, 7, 12):
        xy = rng.uniform(0.0, 3.0, (n, 2))      # some apart, some within 0.3 m
        xy[:(n + 1) // 2] = rng.uniform(0.0, 0.2, ((n + 1) // 2, 2))
        lights = [Light("free", np.array([x, y, 2.0]), np.array([0.0, 0.0, -1.0]), 0)
                  for x, y in xy]
        lights[-1].normal = np.array([0.0, 0.0, 1.0])     # facing away: never a pair
        r, J = prob.separation(lights, with_jac=True)
        want = _pairs_reference(prob, lights)
        assert np.array_equal(r, want) and J.shape == (len(want), 3 * n)
        assert n < 3 or len(want) > 0


def _bits(a):
    return np.ascontiguousarray(a).view(np.int64).tobytes()


def test_mid_air_jacobian_and_cost_give_the_plain_expressions_numbers():
    """Mid-air luminaires' Jacobian (no product with the identity, no concatenation) and
    the robust cost (one scratch array) are bit for bit the written-out expressions', the
    signs of zeros included (unlit points' derivatives are -0.0 before the product)."""
    prob, rng = _problem(3)
    k = len(prob.positions)
    free = [Light("free", np.array([x, y, z]), np.array([0.0, 0.0, -1.0]), 1,
                  indirect=rng.uniform(0, 30, k))
            for x, y, z in [(1.0, 1.0, 2.0), (3.0, 2.2, 1.6), (2.0, 0.5, 2.4)]]
    for lights in (free[:1], free):
        vis = [rng.uniform(size=k) > 0.2 for _ in lights]
        e, de = _reference(prob, lights, vis)
        assert np.any(np.signbit(de) & (de == 0.0))
        Ep = prob.indirect + e.sum(axis=0) if len(lights) > 1 else prob.indirect + e[0]
        for L in lights:
            Ep = Ep + L.indirect
        Ep = Ep + prob.eps_lux
        J_ref = np.concatenate([de[i] @ L.dpos().T for i, L in enumerate(lights)], axis=1)
        J_ref = J_ref / Ep[:, None]
        r, J = prob.residuals(lights, vis, with_jac=True)
        assert _bits(r) == _bits(np.log(Ep) - prob.log_target)
        assert J.shape == J_ref.shape and J.flags.c_contiguous
        assert _bits(J) == _bits(J_ref)
        c = prob.robust_scale
        ref = float(np.sum(prob.w_area * c * c * (np.sqrt(1.0 + (r / c) ** 2) - 1.0)))
        assert prob.cost_of(r) == ref
