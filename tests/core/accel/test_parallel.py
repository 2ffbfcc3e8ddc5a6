"""Rooms in parallel (local worker processes, a local Dask cluster): the same answer as one
room after another, errors and cancelling as in one process, nothing written on cancel."""
import json
import multiprocessing
import os
import subprocess
import sys

import numpy as np
import pytest

from invrad_wb.errors import Cancelled, SceneError, SettingsError
from invrad_wb.core.accel import workers as W
from invrad_wb.core.design.design import design
from invrad_wb.core.design.spec import spec_from_dict
from invrad_wb.core.inverse.locate import locate
from invrad_wb.core.synthetic import generate as g
from invrad_wb.core.synthetic.scenarios import known_scene, match

#: round panels (luminous radius 0.3 m): offices can meet their UGR 19 (a point source is
#: rated as a CIE 147 small source and fails it)
CAT = [{"name": "DL-1000", "flux_lm": 1000, "watts": 8.5, "radius_m": 0.3},
       {"name": "DL-2000", "flux_lm": 2000, "watts": 15.5, "radius_m": 0.3}]


@pytest.fixture(scope="module")
def four_rooms():
    return known_scene("four_rooms", reflectance=0.5)


def _lums(result):
    return [(tuple(map(float, l.position)), tuple(map(float, l.normal)), float(l.flux_lm),
             int(l.room), float(l.score)) for l in result.luminaires]


@pytest.mark.slow
def test_locate_on_two_workers_is_identical_to_one_room_after_another(four_rooms):
    scene, true = four_rooms
    serial = locate(scene, true[0].flux_lm)
    seen = []
    parallel = locate(scene, true[0].flux_lm, workers=2,
                      progress=lambda f, msg: seen.append((f, msg)) or True)
    assert _lums(parallel) == _lums(serial)           # bit for bit
    m = match(parallel.luminaires, true, radius=0.05)
    assert m["found"] == m["true"] == 4 and m["spurious"] == 0
    # progress names the finished rooms and rises to 1
    assert any("4/4 rooms" in m for _, m in seen) and seen[-1][0] == 1.0
    assert all(b[0] >= a[0] for a, b in zip(seen, seen[1:]))
    # the runs came back from the workers without device objects; post-processing again
    # rebuilds them, with the same answer in both
    assert [r.cost for r in parallel.rooms] == [r.cost for r in serial.rooms]
    assert _lums(parallel.repeak(threshold=60)) == _lums(serial.repeak(threshold=60))
    assert not multiprocessing.active_children()


def test_seeds_reach_the_workers(four_rooms):
    """``locate(seeds=)`` on worker processes: each room's seeds travel with its task, and
    the answer is the one of a single process."""
    scene, true = four_rooms
    flux = true[0].flux_lm
    from dataclasses import replace
    seeds = {int(t.room): [replace(t, position=t.position + np.array([0.3, -0.2, 0.0]))]
             for t in true[:2]}
    serial = locate(scene, flux, rooms=[int(t.room) for t in true[:2]], seeds=seeds)
    parallel = locate(scene, flux, rooms=[int(t.room) for t in true[:2]], seeds=seeds,
                      workers=2)
    assert _lums(parallel) == _lums(serial)
    for run in parallel.rooms:
        step = [x for x in run.trace if "seeded" in x]
        assert len(step) == 1 and step[0]["seeded"] == 1, run.trace


@pytest.mark.slow
def test_design_on_two_workers_is_identical_to_one_room_after_another():
    sc, _ = g.floor_of_rooms(rooms=((4.0, 3.0), (5.0, 4.0), (3.0, 3.0)), cell=0.4)
    sp = spec_from_dict({"catalogue": CAT, "rooms": {"*": {"room_type": "office"}}})
    a = design(sc, sp)
    b = design(sc, sp, workers=2)
    sig = [(r.room, [(tuple(l.position), l.flux_lm) for l in r.luminaires], r.metrics.em,
            r.metrics.u0, r.watts) for r in a.rooms]
    assert sig == [(r.room, [(tuple(l.position), l.flux_lm) for l in r.luminaires],
                    r.metrics.em, r.metrics.u0, r.watts) for r in b.rooms]
    assert a.compliant and b.compliant and len(a.luminaires) >= 3


def test_locate_on_a_local_dask_cluster_is_identical(four_rooms):
    pytest.importorskip("distributed")     # installed by the setup; absent only by hand
    scene, true = four_rooms
    serial = locate(scene, true[0].flux_lm, rooms=[0, 1])
    on_dask = locate(scene, true[0].flux_lm, rooms=[0, 1], workers=2, dask="local")
    assert _lums(on_dask) == _lums(serial)


def _boom(i):
    if i == 2:
        raise SceneError("face 7 has no room", "floor.ply")
    return i * i


def test_a_worker_error_reaches_the_caller_with_its_message():
    assert W.map_rooms(_boom, [(0,), (1,), (3,)], workers=2) == [0, 1, 9]
    with pytest.raises(SceneError, match="floor.ply: face 7 has no room"):
        W.map_rooms(_boom, [(0,), (1,), (2,), (3,)], workers=2)
    assert not multiprocessing.active_children()


def _die(i):
    if i == 1:
        os._exit(3)             # what the OOM killer or a segfault leaves: no exception
    import time
    time.sleep(0.5)
    return i


def test_a_worker_that_dies_is_an_error_not_a_hang():
    from invrad_wb.errors import InvradError
    with pytest.raises(InvradError, match="worker process stopped unexpectedly.*room 2"):
        W.map_rooms(_die, [(0,), (1,), (2,)], workers=2)
    assert not multiprocessing.active_children()


def test_cancel_stops_every_worker(four_rooms):
    scene, true = four_rooms
    calls = []

    def cancel_at_once(frac, msg):
        calls.append(msg)
        return False
    with pytest.raises(Cancelled):
        locate(scene, true[0].flux_lm, workers=2, progress=cancel_at_once)
    assert len(calls) == 1
    assert not multiprocessing.active_children()


def test_embedded_python_finds_its_interpreter_else_rooms_run_in_process(monkeypatch,
                                                                            tmp_path):
    # inside FreeCAD sys.executable is FreeCAD itself: workers use the Python it embeds
    monkeypatch.setattr(sys, "executable", "/usr/bin/FreeCAD")
    monkeypatch.delenv("INVRAD_PYTHON", raising=False)
    exe = W.worker_python()
    assert exe and os.path.basename(exe) == "python%d.%d" % sys.version_info[:2]
    cp = subprocess.run([exe, "-c", "import sys; print(sys.version_info[:2])"],
                        capture_output=True, text=True, timeout=60)
    assert cp.stdout.strip() == str(tuple(sys.version_info[:2]))
    # no such interpreter: rooms run in this process
    for attr in ("base_prefix", "base_exec_prefix", "prefix"):
        monkeypatch.setattr(sys, attr, str(tmp_path))
    assert W.worker_python() is None
    pids = W.map_rooms(_pid, [()] * 3, workers=2)
    assert set(pids) == {os.getpid()}


def test_workers_from_an_embedding_program_do_not_rerun_its_script(tmp_path):
    # what FreeCAD does: its executable is not Python and __main__ is a script that
    # imports FreeCAD; the workers must start without running it
    script = tmp_path / "fc_script.py"
    script.write_text(
        "import os, sys\n"
        "if __name__ != '__main__':\n"
        "    raise SystemExit('the embedding script ran in a worker')\n"
        "sys.executable = '/usr/bin/FreeCAD'\n"
        "from invrad_wb.core.accel import workers as W\n"
        "from test_parallel import _pid\n"
        "pids = W.map_rooms(_pid, [()] * 4, workers=2)\n"
        "assert os.getpid() not in pids, pids\n"
        "print('ok', len(set(pids)))\n")
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(
        [os.path.dirname(os.path.abspath(__file__)), os.environ.get("PYTHONPATH", "")]))
    env.pop("INVRAD_PYTHON", None)
    cp = subprocess.run([sys.executable, str(script)], capture_output=True, text=True,
                        timeout=120, env=env)
    assert cp.returncode == 0 and cp.stdout.startswith("ok"), cp.stderr[-2000:]


def _pid():
    return os.getpid()


@pytest.mark.parametrize("value", [0, "0", -2, 1.5, "many", True])
def test_bad_worker_counts_are_refused(value):
    with pytest.raises(SettingsError, match="workers must be a positive whole number"):
        W.check_workers(value)


@pytest.mark.slow
def test_cli_workers_same_json_and_cancel_writes_nothing(tmp_path, four_rooms):
    from invrad_wb.core.io.sceneio import write_scene
    scene, true = four_rooms
    write_scene(tmp_path / "four.ply", scene)
    run = [sys.executable, "-m", "invrad_wb", "locate", "four.ply", "--flux", "3000"]
    out = {}
    for w in ("1", "2"):
        cp = subprocess.run(run + ["-o", f"r{w}.json", "--workers", w], cwd=tmp_path,
                            capture_output=True, text=True, timeout=300)
        assert cp.returncode == 0, cp.stderr
        out[w] = json.loads((tmp_path / f"r{w}.json").read_text())["luminaires"]
    assert out["1"] == out["2"] and len(out["1"]) == 4
    cp = subprocess.run(run + ["-o", "r.json", "--workers", "none"], cwd=tmp_path,
                        capture_output=True, text=True, timeout=300)
    assert cp.returncode == 2 and "--workers" in cp.stderr and "'none'" in cp.stderr
    assert not (tmp_path / "r.json").exists()
    # interrupted while the workers run (Ctrl-C reaches the whole process group): exit
    # 130, no result file, no worker left
    # (Python's own SIGINT handler, as in a terminal: a background job inherits it ignored)
    code = ("import sys, signal, threading, os\n"
            "signal.signal(signal.SIGINT, signal.default_int_handler)\n"
            "from invrad_wb.cli import main\n"
            "threading.Timer(3.0, lambda: os.kill(os.getpid(), signal.SIGINT)).start()\n"
            "sys.exit(main(sys.argv[1:]))\n")
    cp = subprocess.run([sys.executable, "-c", code] + run[3:] + ["-o", "c.json",
                        "--workers", "2", "--votes-per-m2", "3000"], cwd=tmp_path,
                        capture_output=True, text=True, timeout=300)
    assert cp.returncode == 130, (cp.returncode, cp.stderr[-2000:])
    assert not (tmp_path / "c.json").exists()
    assert not [p for p in os.listdir(tmp_path) if p.startswith(".")]


def test_cli_batch_of_a_folder_same_as_one_by_one_and_a_bad_file_named(tmp_path):
    from invrad_wb.core.io.sceneio import write_scene
    proj = tmp_path / "project"
    proj.mkdir()
    for name in ("one_ceiling", "two_ceiling"):
        scene, _ = known_scene(name, cell=0.2)
        write_scene(proj / f"{name}.ply", scene)
    (proj / "broken.ply").write_text("ply\nformat ascii 1.0\n")
    (proj / "notes.txt").write_text("not a scene")
    base = [sys.executable, "-m", "invrad_wb", "locate"]
    cp = subprocess.run(base + ["project", "--flux", "3000", "-o", "results"], cwd=tmp_path,
                        capture_output=True, text=True, timeout=300)
    assert cp.returncode == 2
    assert "broken.ply" in cp.stderr and "2 of 3 scene(s) located" in cp.stdout
    assert sorted(os.listdir(tmp_path / "results")) == ["one_ceiling.json", "two_ceiling.json"]
    for name, n in (("one_ceiling", 1), ("two_ceiling", 2)):
        cp = subprocess.run(base + [f"project/{name}.ply", "--flux", "3000", "-o", "one.json"],
                            cwd=tmp_path, capture_output=True, text=True, timeout=300)
        assert cp.returncode == 0, cp.stderr
        single = json.loads((tmp_path / "one.json").read_text())["luminaires"]
        batch = json.loads((tmp_path / "results" / f"{name}.json").read_text())["luminaires"]
        assert batch == single and len(single) == n
    # one scene's sidecar cannot serve several scenes
    cp = subprocess.run(base + ["project", "--flux", "3000", "-o", "r2", "--lux", "x.json"],
                        cwd=tmp_path, capture_output=True, text=True, timeout=300)
    assert cp.returncode == 2 and "--lux" in cp.stderr and not (tmp_path / "r2").exists()


def _env():
    return {k: os.environ.get(k) for k in ("INVRAD_MEMORY_LIMIT", "POCL_MAX_PTHREAD_COUNT")}


def test_workers_share_the_memory_budget(monkeypatch):
    # two rooms at their limit on two workers must not take twice the budget
    monkeypatch.setenv("INVRAD_MEMORY_LIMIT", "2G")
    monkeypatch.delenv("POCL_MAX_PTHREAD_COUNT", raising=False)
    env = W.map_rooms(_env, [()] * 2, workers=2)
    assert env[0]["INVRAD_MEMORY_LIMIT"] == str(1 << 30)
    assert int(env[0]["POCL_MAX_PTHREAD_COUNT"]) == max(1, W.usable_cores() // 2)
    assert os.environ["INVRAD_MEMORY_LIMIT"] == "2G"             # this process unchanged
    assert "POCL_MAX_PTHREAD_COUNT" not in os.environ


def _blas_threads():
    from threadpoolctl import threadpool_info
    import numpy.linalg  # noqa: F401  (numpy's BLAS is loaded)
    return sorted({d["num_threads"] for d in threadpool_info() if d["user_api"] == "blas"})


def test_rooms_run_blas_on_one_thread_in_process_and_on_workers():
    pytest.importorskip("threadpoolctl")
    before = _blas_threads()
    if not before:        # Debian trixie's numpy: a BLAS threadpoolctl does not see
        pytest.skip("numpy's BLAS is not one threadpoolctl can control")
    assert W.map_rooms(_blas_threads, [()] * 2, workers=1) == [[1], [1]]
    assert W.map_rooms(_blas_threads, [()] * 2, workers=2) == [[1], [1]]
    # and with fine-grained progress (the in-process path that passes report=)
    got = W.map_rooms(lambda report: _blas_threads(), [()], report=lambda i, n: None)
    assert got == [[1]]
    assert _blas_threads() == before                              # restored afterwards


@pytest.mark.slow
def test_cli_design_batch_same_as_one_by_one(tmp_path):
    from invrad_wb.core.io.sceneio import write_scene
    proj = tmp_path / "project"
    proj.mkdir()
    for name, size in (("small", (4.0, 3.0, 2.8)), ("big", (6.0, 4.0, 2.8))):
        sc = g.box_room(size=size, cell=0.5)
        write_scene(proj / f"{name}.ply", sc, lux=np.full(len(sc.vertices), np.nan))
    (proj / "broken.ply").write_text("ply\n")
    (tmp_path / "d.json").write_text(json.dumps(
        {"catalogue": CAT, "rooms": {"*": {"room_type": "office"}}}))
    base = [sys.executable, "-m", "invrad_wb", "design"]
    cp = subprocess.run(base + ["project", "--spec", "d.json", "-o", "res", "--schedule",
                                "sched"], cwd=tmp_path, capture_output=True, text=True,
                        timeout=300)
    assert cp.returncode == 2 and "broken.ply" in cp.stderr, cp.stderr
    assert sorted(os.listdir(tmp_path / "res")) == ["big.json", "small.json"]
    assert sorted(os.listdir(tmp_path / "sched")) == ["big.csv", "small.csv"]
    for name in ("small", "big"):
        cp = subprocess.run(base + [f"project/{name}.ply", "--spec", "d.json", "-o",
                                    "one.json"], cwd=tmp_path, capture_output=True,
                            text=True, timeout=300)
        assert cp.returncode == 0, cp.stderr
        one = json.loads((tmp_path / "one.json").read_text())
        batch = json.loads((tmp_path / "res" / f"{name}.json").read_text())
        strip = lambda d: [{k: v for k, v in r.items() if k != "seconds"} for r in d["rooms"]]
        assert strip(one) == strip(batch)
        assert one["luminaires"] == batch["luminaires"] and one["luminaires"]
