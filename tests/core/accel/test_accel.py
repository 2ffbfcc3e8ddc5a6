"""Every OpenCL kernel against its numpy twin, from the one registry of pairs.

Each registered pair must have a case below (a new kernel without one fails
``test_every_pair_has_a_case``); tolerances state the physics, so they hold on any device:
float32 arithmetic moves a value by a few 1e-4 relative, a grazing ray or a sample on a
pixel border may flip, but totals stay.
"""
import os
import subprocess
import sys

import numpy as np
import pytest

from invrad_wb.core.accel.registry import pairs
from invrad_wb.core.geometry.bvh import BVH
from invrad_wb.core.model.luminaires import Luminaire
from invrad_wb.core.synthetic import generate as g
from repo_paths import ROOT


def _direct():
    s = g.pillar_room(cell=0.2)
    from invrad_wb.core.model.photometry import Photometry
    gam = np.arange(181.0)
    narrow = Photometry(np.tile(np.where(gam < 40, np.cos(np.radians(gam)), 0.0), (361, 1)),
                        name="40 degrees")
    # lambertian (the direct kernel) and with a distribution (the photometric kernel);
    # both cast the pillar's shadow
    lums = [Luminaire([1.5, 2.0, 2.99], [0, 0, -1], 3000, 0.25),
            Luminaire([0.01, 1.0, 2.0], [1, 0, 0], 1500),
            Luminaire([4.5, 1.0, 2.9], [-0.6, 0.5, -0.6], 2000, photometry=narrow)]
    args = (s.vertices, s.vertex_normals, lums)
    kw = {"bvh": BVH(s.triangles)}

    def same(a, b):
        assert (a == 0).sum() > 100                            # shadows exist
        assert np.sum(np.abs(a - b) > 1e-3 * a.max() + 1e-3) <= 3   # grazing rays
    return args, kw, same


def _photometric():
    s = g.pillar_room(cell=0.2)
    from invrad_wb.core.model.photometry import Photometry
    gam, c = np.arange(181.0), np.radians(np.arange(361.0))
    # the same in every C plane (the kernel skips the C angle) and one that is not (twice
    # as bright along C = 0 as across it: the luminaire's C = 0 axis, its own c0 where
    # it has one, must turn it)
    narrow = Photometry(np.tile(np.where(gam < 40, np.cos(np.radians(gam)), 0.0), (361, 1)),
                        name="40 degrees")
    oval = Photometry(np.outer(1.0 + 0.8 * np.cos(c), np.maximum(np.cos(np.radians(gam)), 0.0)
                               + 0.1 * (gam < 100)), name="oval")
    lums = [Luminaire([4.5, 1.0, 2.9], [-0.6, 0.5, -0.6], 2000, photometry=narrow),
            Luminaire([1.5, 2.0, 2.9], [0, 0, -1], 3000, 0.25, photometry=oval),
            Luminaire([0.2, 3.0, 1.5], [1, -0.2, 0.1], 1000, photometry=oval, c0=[0, 0, 1]),
            Luminaire([3.0, 0.1, 2.0], [0.3, 1, 0.5], 1500, photometry=oval, c0=[1, 0, 0.3])]
    args = (s.vertices, s.vertex_normals, lums)

    def same(a, b):
        assert (a == 0).sum() > 3 and a.max() > 100               # dark corners, lit spots
        # float32: a few 1e-4 relative; a grazing shadow ray may flip at a few points
        assert np.sum(np.abs(a - b) > 1e-3 * a.max() + 1e-3) <= max(3, len(a) // 500)
        assert abs(a.sum() - b.sum()) < 1e-3 * a.sum()
    return args, {"bvh": BVH(s.triangles)}, same


def _occlusion():
    s = g.pillar_room(cell=0.3)
    rng = np.random.default_rng(7)
    lo, hi = np.array([0.01, 0.01, 0.01]), np.array([5.99, 3.99, 2.99])
    p, q = rng.uniform(lo, hi, (3000, 3)), rng.uniform(lo, hi, (3000, 3))

    def same(a, b):
        assert a.sum() > 100
        assert np.sum(a != b) <= 3                            # grazing rays at float32
    return (BVH(s.triangles), p, q), {}, same


def _form_factors():
    from invrad_wb.core.forward.radiosity import RadiosityModel
    m = RadiosityModel(g.l_room(), backend="numpy", patch_size=0.5)
    room = m.rooms[0]
    pts, nrm = m.vertex_receivers()
    sel = np.flatnonzero(m.patch_room[np.maximum(m.vertex_patch, 0)] == room.room)[::7]
    local = m.vertex_patch[sel] - room.sl.start
    args = (pts[sel], nrm[sel], room.patches.plane[local], room.patches, local, room.vis)

    def same(a, b):
        assert a.sum() > 1.0
        np.testing.assert_allclose(b, a, rtol=2e-3, atol=2e-5)
    return args, {}, same


def _patch_form_factors():
    from invrad_wb.core.forward.radiosity import RadiosityModel
    # the L-shaped room: a re-entrant corner, so visibility rows matter
    m = RadiosityModel(g.l_room(), backend="numpy", patch_size=0.5)
    room = m.rooms[0]
    ps, par = room.patches, room.sample_parent
    args = (room.sample_point, ps.normal[par], ps, par, room.sample_weight, room.vis)

    def same(a, b):
        assert a.shape == (ps.n, ps.n) and b.shape == a.shape
        # rows sum to the fraction of the hemisphere the room's other patches cover
        assert 0.5 < np.median(a[ps.emits].sum(axis=1)) < 1.05
        np.testing.assert_allclose(b, a, rtol=2e-3, atol=2e-5)
        np.testing.assert_allclose(b.sum(axis=1), a.sum(axis=1), rtol=1e-3, atol=1e-5)
    return args, {"centre": room.centre}, same


def _votes():
    from invrad_wb.core.forward.render import render
    from invrad_wb.core.inverse.locate import occluding_faces
    from invrad_wb.core.inverse.sampling import voting_points
    from invrad_wb.core.inverse.votemaps import build_canvas
    from invrad_wb.core.inverse.votes import vote_weights
    s = g.pillar_room((4, 3, 2.6), pillar=((1.9, 1.3), (2.2, 1.6)), cell=0.25)
    lums = [Luminaire([1.0, 1.5, 2.6], [0, 0, -1], 2000)]
    s = s.with_vertex_lux(render(s, lums, interreflection=False, backend="numpy"))
    pts = voting_points(s, density=30)
    canvas = build_canvas(s, 0, pixel=0.15, dummy_spacing=0.3)
    W = vote_weights(canvas, pts, pts.lux, "illumination")
    kw = {"bvh": BVH(s.triangles[occluding_faces(s)])}

    def same(a, b):
        assert a.sum() > 10
        # the same votes, except samples within float32 rounding of a pixel border
        assert abs(a.sum() - b.sum()) < 2e-3 * a.sum()
        assert np.mean(np.abs(a - b) > 2e-3 * a.max() + 0.05) < 2e-3
        assert np.argmax(a) == np.argmax(b) or b[np.argmax(a)] >= 0.99 * b.max()
    return (canvas, pts, W, pts.lux, 2000.0), kw, same


#: one small deterministic case per registered pair: () -> (args, kwargs, same(numpy, opencl))
CASES = {"direct_illuminance": _direct, "photometric_illuminance": _photometric,
         "segments_occluded": _occlusion,
         "form_factors": _form_factors, "patch_form_factors": _patch_form_factors,
         "votes_exact": _votes, "votes_ellipse": _votes}


def test_every_pair_has_a_case():
    # runs without a device too, so a kernel added without a parity case fails everywhere
    assert sorted(pairs()) == sorted(CASES)


@pytest.mark.opencl
@pytest.mark.parametrize("name", sorted(pairs()))
def test_opencl_matches_its_numpy_twin(name):
    assert name in CASES, f"the pair {name!r} has no parity case in tests/core/accel/test_accel.py"
    pair = pairs()[name]
    args, kw, same = CASES[name]()
    same(pair.numpy(*args, **kw), pair.opencl(*args, **kw))


def test_the_switch_turns_opencl_off():
    code = ("import warnings; warnings.simplefilter('ignore');"
            "from invrad_wb.core.accel import clenv;"
            "from invrad_wb.core.accel.registry import implementation, pairs;"
            "print(clenv.opencl_available(), clenv.check_backend('auto'),"
            " implementation('direct_illuminance', 'auto') is pairs()"
            "['direct_illuminance'].numpy)")
    env = dict(os.environ, INVRAD_OPENCL="0")
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True,
                         text=True, timeout=120, cwd=ROOT)
    assert out.stdout.split() == ["False", "numpy", "True"], out.stderr


@pytest.mark.opencl
def test_compiler_messages_stay_off_the_terminal_and_in_the_build_log(tmp_path):
    # a kernel the compiler warns about; a fresh -D value so that no cache answers
    (tmp_path / "noisy.cl").write_text("__kernel void noisy(__global int *o)\n"
                                       "{\n    int x = 3.7;\n    o[get_global_id(0)] = x;\n}\n")
    code = ("import sys, time; from invrad_wb import constants as C;"
            f"C.KERNELS_DIR = {str(tmp_path)!r};"
            "from invrad_wb.core.accel import device;"
            "env = device.get_env(); env.program('noisy', (f'-D RUN={time.time_ns()}',));"
            "env.program('noisy', (f'-D RUN=0',)); n = len(device.builds);"
            "env.program('noisy', (f'-D RUN=0',));"
            "print(n, len(device.builds), repr(device.builds[0]['log']))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         timeout=300, cwd=ROOT)
    assert out.returncode == 0, out.stderr
    assert out.stderr == ""                                  # nothing on the terminal
    built, after, log = out.stdout.split(" ", 2)
    assert built == after == "2"                             # built once per process
    assert "3.7" in log or "warning" in log.lower()          # the message is kept


# ------------------------------------------------------------------ one dispatch, one policy
def test_the_backend_is_resolved_in_one_place(monkeypatch):
    from invrad_wb.core.accel import device
    from invrad_wb.core.accel.registry import implementation
    from invrad_wb.errors import DeviceError, SettingsError
    pair = pairs()["segments_occluded"]
    assert implementation("segments_occluded", "numpy") is pair.numpy
    with pytest.raises(SettingsError, match="backend must be one of"):
        implementation("segments_occluded", "cuda")
    with pytest.raises(KeyError, match="no OpenCL/numpy pair named 'teleport'"):
        implementation("teleport", "numpy")
    monkeypatch.setenv("INVRAD_OPENCL", "0")
    with pytest.raises(DeviceError, match=r"switched off \(INVRAD_OPENCL=0\)"):
        implementation("segments_occluded", "opencl")
    monkeypatch.setattr(device, "_warned", False)
    with pytest.warns(RuntimeWarning, match="INVRAD_OPENCL=0.*numpy backend"):
        assert implementation("segments_occluded", "auto") is pair.numpy
    # the numpy twin computes without a device: a wall between p and q blocks, a gap does not
    from invrad_wb.core.forward.occlusion import segments_occluded
    wall = BVH(np.array([[[1, -1, -1], [1, 1, -1], [1, 0, 2]]], float))
    got = segments_occluded(wall, [[0, 0, 0], [0, 5, 0]], [[2, 0, 0], [2, 5, 0]], "auto")
    assert got.tolist() == [True, False]


def test_without_pyopencl_auto_means_numpy_and_opencl_says_what_to_install(monkeypatch):
    from invrad_wb.core.accel import device
    from invrad_wb.errors import DeviceError
    monkeypatch.setitem(sys.modules, "pyopencl", None)     # import fails
    monkeypatch.setattr(device, "_env", None)
    monkeypatch.setattr(device, "_warned", True)
    monkeypatch.delenv("INVRAD_OPENCL", raising=False)
    assert device.check_backend("auto") == "numpy"
    assert "cannot import pyopencl" in device.opencl_unavailable_reason()
    with pytest.raises(DeviceError, match="Install the 'pyopencl' package"):
        device.check_backend("opencl")


def _fake_cl(*platform_types):
    """A pyopencl stand-in: one platform per entry, each a list of device type names."""
    from types import SimpleNamespace as NS
    kinds = NS(GPU=4, CPU=2, ACCELERATOR=8)
    plats = [NS(get_devices=lambda devs=[NS(type=getattr(kinds, t), name=f"{t}{pi}.{di}")
                                         for di, t in enumerate(types)]: devs)
             for pi, types in enumerate(platform_types)]
    return NS(get_platforms=lambda: plats, device_type=kinds)


def test_device_policy_prefers_a_gpu_then_a_cpu_and_honours_pyopencl_ctx(monkeypatch):
    from invrad_wb.core.accel.device import _pick_device
    from invrad_wb.errors import DeviceError
    monkeypatch.delenv("PYOPENCL_CTX", raising=False)
    assert _pick_device(_fake_cl(["CPU"], ["ACCELERATOR", "GPU"])).name == "GPU1.1"
    assert _pick_device(_fake_cl(["ACCELERATOR"], ["CPU"])).name == "CPU1.0"
    monkeypatch.setenv("PYOPENCL_CTX", "1:0")
    assert _pick_device(_fake_cl(["CPU"], ["ACCELERATOR", "GPU"])).name == "ACCELERATOR1.0"
    monkeypatch.setenv("PYOPENCL_CTX", "0")
    assert _pick_device(_fake_cl(["CPU"], ["GPU"])).name == "CPU0.0"
    monkeypatch.setenv("PYOPENCL_CTX", "3")
    with pytest.raises(DeviceError, match="PYOPENCL_CTX='3' names no OpenCL device"):
        _pick_device(_fake_cl(["CPU"]))
    monkeypatch.delenv("PYOPENCL_CTX")
    with pytest.raises(DeviceError, match="no device"):
        _pick_device(_fake_cl([]))


def test_device_buffer_rejects_an_unknown_access():
    from invrad_wb.core.accel.buffers import device_buffer
    with pytest.raises(ValueError, match="access must be one of"):
        device_buffer(None, np.zeros(3), "append")


@pytest.mark.opencl
def test_device_buffers_carry_data_both_ways():
    from invrad_wb.core.accel.buffers import device_buffer, float4
    from invrad_wb.core.accel.device import get_env
    env = get_env()
    host = float4([[1.5, -2.0, 3.25], [0.0, 4.0, -1.0]], [7.0, 8.0])
    assert host.dtype == np.float32 and host[:, 3].tolist() == [7.0, 8.0]
    back = np.empty_like(host)
    for access in ("read", "readwrite"):
        env.cl.enqueue_copy(env.queue, back, device_buffer(env, host, access))
        assert np.array_equal(back, host)
    assert device_buffer(env, np.empty(10, np.int32), "write").size == 40
    assert device_buffer(env, np.zeros(0, np.float32)).size == 16     # empty: a stand-in
