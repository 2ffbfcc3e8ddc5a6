"""The voting table: layout, checksum, declining cases and lookup against fresh physics."""
import importlib.util
import json
import math
import os
import shutil

import numpy as np
import pytest

from invrad_wb import constants as C
from invrad_wb.core.inverse import formfactor as ff
from invrad_wb.core.inverse import tablefit as tf
from invrad_wb.core.inverse.table import VotingTable, load_voting_table, table_paths
from invrad_wb.errors import InvradError


@pytest.fixture(scope="module")
def table():
    return load_voting_table()


def test_layout_and_resolution(table):
    A, L = table.shape
    assert isinstance(table, VotingTable)
    assert table is load_voting_table()                 # loaded once
    assert A >= 180 and L >= 256                         # thesis: 36 angles, 250 levels
    np.testing.assert_allclose(np.degrees(table.angles), np.arange(1, A + 1) * 180.0 / A)
    assert table.angles[-1] == pytest.approx(np.pi)
    assert table.q[0] == 1.0 and table.q_min <= 1e-3
    np.testing.assert_allclose(table.q, np.exp(-table.lam ** 2), rtol=1e-15)
    np.testing.assert_allclose(np.diff(table.lam), table.lam_step, rtol=1e-9)
    # finer than the thesis' level step everywhere (it stepped 0.0002 of ~0.08 = 1/400)
    assert np.all(-np.diff(table.q) < 1 / 25) and np.all(-np.diff(np.log(table.q[1:])) < 0.05)
    for arr, shape in ((table.params, (A, L, 5)), (table.fit_error, (A, L)),
                       (table.angle_info, (A, 4))):
        assert arr.dtype == np.float32 and arr.flags.c_contiguous and arr.shape == shape
        assert not arr.flags.writeable
    i, j, p = 37, 201, 3                                 # documented flat index
    assert table.params.ravel()[(i * L + j) * 5 + p] == table.params[i, j, p]
    assert np.all(table.params[:, 0] == 0) and np.all(table.fit_error[:, 0] == 0)
    meta = table.meta
    assert meta["sha256"] and meta["numpy"] and meta["seconds"] > 0
    assert meta["arrays"]["params"]["shape"] == [A, L, 5]


def test_per_angle_values_are_the_closed_form(table):
    mx = ff.maximum_closed_form(1.0, table.angles)
    np.testing.assert_allclose(table.x_max, mx.x, rtol=1e-14)
    np.testing.assert_allclose(table.e_max, mx.e, rtol=1e-14)
    np.testing.assert_allclose(table.rotation, mx.rotation, atol=1e-14)
    np.testing.assert_allclose(table.r_max, np.hypot(1.0, mx.x), rtol=1e-14)
    np.testing.assert_allclose(table.angle_info[:, 1], mx.x, rtol=1e-6)


def test_fit_quality_over_the_table(table):
    fe = table.fit_error[:, 1:]
    assert np.all(np.isfinite(fe))
    assert np.median(fe) < 0.02 and fe.max() < 0.05
    # near the maximum and at normal incidence the contours are ellipses / circles
    near = table.q > 0.9
    assert table.fit_error[:, near].max() < 0.002
    assert table.fit_error[-1].max() < 1e-4
    # symmetry: y_m is zero, a and b positive beyond q = 1
    assert np.abs(table.params[..., 4]).max() < 1e-6
    assert np.all(table.params[:, 1:, :2] > 0)


def test_normal_incidence_gives_the_closed_form_circle(table):
    q = np.array([0.999, 0.93, 0.5, 0.07, 2e-3, 3e-4])
    for h in (0.37, 3.2, 8.9):
        e = q / (np.pi * h * h)
        ok, x_max, rot, a, b, d, xm, ym = table.lookup(h, np.pi, e)
        rho = h * np.sqrt(q ** -0.5 - 1)
        assert ok.all()
        np.testing.assert_allclose(a, rho, rtol=2e-4)
        np.testing.assert_allclose(b, rho, rtol=2e-4)
        assert np.abs(np.concatenate([d, xm / h, ym / h, x_max / h, rot])).max() < 1e-6


def test_lookup_at_nodes_is_the_stored_entry(table):
    i, j = 89, 300
    for h in (0.37, 3.2):
        alpha = table.angles[i]
        e = table.q[j] * table.e_max[i] / h ** 2
        ok, x_max, rot, a, b, d, xm, ym, err = table.lookup(h, alpha, e, return_error=True)
        assert ok
        P = table.params[i, j].astype(np.float64)
        s = h * table.r_max[i]
        np.testing.assert_allclose([a, b, xm, ym], P[[0, 1, 3, 4]] * s, rtol=1e-6,
                                   atol=1e-12)
        assert d == pytest.approx(P[2], rel=1e-6)
        assert x_max == pytest.approx(h * table.x_max[i], rel=1e-12)
        assert rot == pytest.approx(table.rotation[i], abs=1e-12)
        assert err == pytest.approx(table.fit_error[i, j], rel=1e-5)


@pytest.mark.parametrize("alpha_deg", [90.0, 135.0, 62.5, 3.5])
def test_lookup_matches_fresh_fits_at_any_distance(table, alpha_deg):
    """Scale invariance: fits at h = 0.37, 3.2, 8.9 m agree with the unit-distance table."""
    alpha = math.radians(alpha_deg)
    q = np.array([0.97, 0.6, 0.2, 0.03, 2.5e-3])
    for h in (0.37, 3.2, 8.9):
        e = q * float(ff.maximum_closed_form(h, alpha).e)
        fit = tf.fit_deformed_ellipse(h, alpha, e, method="orthogonal")
        ok, x_max, rot, a, b, d, xm, ym = table.lookup(h, alpha, e)
        assert ok.all()
        np.testing.assert_allclose(x_max, fit.x_max, rtol=1e-12)
        np.testing.assert_allclose(rot, fit.rotation, atol=1e-12)
        size = fit.params[:, 1]
        got = np.stack([a, b, d, xm, ym], axis=-1)
        dev = np.abs(got - fit.params)
        dev[:, [0, 1, 3, 4]] /= size[:, None]
        assert dev.max() < 2e-3, dev.max()
        # and what matters for voting: the looked-up curve lies on the true contour
        _, gmax, _ = tf.geometric_error(h, alpha, e, got, x_max)
        assert np.all(gmax < 0.035)


def test_lookup_ellipse_in_space_reproduces_the_illuminance(table):
    """End to end: luminaires placed on the looked-up 3D curve give the observed lux."""
    rng = np.random.default_rng(11)
    n = np.array([0.0, 0.0, -1.0])                       # a ceiling, facing down
    for alpha_deg, h, lux, flux in ((90.0, 1.4, 60.0, 1500.0), (135.0, 2.2, 90.0, 2000.0),
                                    (180.0, 2.8, 30.0, 1000.0), (120.0, 0.6, 300.0, 800.0)):
        alpha = math.radians(alpha_deg)
        s = np.array([1.0, 2.0, 3.0 - h])                # ceiling plane z = 3
        w = np.array([math.cos(0.3), math.sin(0.3), 0.0])  # in-plane, arbitrary
        m = math.cos(alpha) * n + math.sin(alpha) * w
        v = np.cross(n, w)
        ok, x_max, rot, a, b, d, xm, ym = table.lookup(h, alpha, lux / flux)
        assert ok
        foot = s - h * n
        centre = foot + (x_max + xm) * w + ym * v
        t = rng.uniform(0, 2 * np.pi, 64)
        c = (centre + (b * (np.cos(t) + d * np.cos(2 * t)))[:, None] * w
             + (a * np.sin(t))[:, None] * v)
        dvec = s - c
        r = np.linalg.norm(dvec, axis=1)
        E = flux * np.maximum(dvec @ n / r, 0) * np.maximum((c - s) @ m / r, 0) / (np.pi * r * r)
        np.testing.assert_allclose(E, lux, rtol=0.05)
        # the rotated normal points at the maximum
        k = np.cross(v, m)
        direction = m * math.cos(rot) + k * math.sin(rot)
        hit = s + direction * (-h / (direction @ n))
        np.testing.assert_allclose(hit, foot + x_max * w, atol=1e-9)


def test_lookup_declines(table):
    e_max = 1 / np.pi
    h = np.array([0.0, -1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0, np.nan, 1.0, 1.0])
    alpha = np.array([np.pi, np.pi, 0.0, 1e-3, np.pi, np.pi, np.pi, np.pi, 4.0, np.pi,
                      np.pi, np.pi])
    e = np.array([0.1, 0.1, 0.1, 1e-12, 0.0, -0.1, 1.01 * e_max, np.inf, 0.1, 0.1,
                  0.5 * table.q_min * e_max, np.nan])
    ok, x_max, rot, a, b, d, xm, ym = table.lookup(h, alpha, e)
    assert not ok.any()
    for arr in (x_max, rot, a, b, d, xm, ym):
        assert np.all(arr == 0)
    # the maximum itself is a valid vote for a point: a = b = 0
    mx = ff.maximum_closed_form(2.0, math.radians(60))
    ok, x_max, rot, a, b, d, xm, ym = table.lookup(2.0, math.radians(60), float(mx.e))
    assert ok and a == 0 and b == 0
    assert x_max == pytest.approx(float(mx.x))
    # broadcasting: one point, many planes
    ok, *_ = table.lookup(np.array([1.0, 2.0, 3.0]), np.pi, 0.01)
    assert ok.shape == (3,) and ok.all()


def test_checksum_failure_names_the_file(tmp_path):
    npz, js = table_paths()
    dst = tmp_path / "tables"
    dst.mkdir()
    shutil.copy(npz, dst)
    shutil.copy(js, dst)
    assert load_voting_table(dst).shape == load_voting_table().shape
    bad = dst / "voting_table.npz"
    raw = bytearray(bad.read_bytes())
    raw[len(raw) // 2] ^= 0xFF
    bad.write_bytes(bytes(raw))
    with pytest.raises(InvradError, match="corrupt") as exc:
        load_voting_table(dst, reload=True)
    assert str(bad) in str(exc.value) and "make_voting_table.py" in str(exc.value)
    os.remove(bad)
    with pytest.raises(InvradError, match="missing") as exc:
        load_voting_table(dst, reload=True)
    assert "make_voting_table.py" in str(exc.value)


def test_wrong_format_is_refused(tmp_path):
    npz, js = table_paths()
    shutil.copy(npz, tmp_path)
    meta = json.loads(open(js).read())
    meta["format"] = 999
    (tmp_path / "voting_table.json").write_text(json.dumps(meta))
    with pytest.raises(InvradError, match="format"):
        load_voting_table(tmp_path)


def test_generator_check_reproduces_stored_entries():
    path = os.path.join(C.TABLES_DIR, "make_voting_table.py")
    spec = importlib.util.spec_from_file_location("make_voting_table", path)
    gen = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(gen)
    meta = load_voting_table().meta["parameters"]
    npz, _ = table_paths()
    assert gen.check(npz, 6, meta["k"], meta["k_orth"], meta["n_check"])
