"""The background area (EN 12464-1:2021 4.3.3) of the six rooms of
``bench_design_radiance.py``, judged by Radiance on their existing designs (figures only).

1. **As designed.** Each room's task area is the room less a 0.5 m border and its immediate
   surroundings (0.5 m) fill that border: no floor is left for a background area, and the
   design's background item is "none" (:func:`~invrad_wb.core.design.background.background_grid`
   returns None). Printed per room.
2. **A task area set in** (the largest border zone of 4.0, 3.5, ... 1.0 m that still leaves
   a task area and a background): the band 3 m beyond its surroundings, or what remains of
   the room, lit by the room's existing invrad design (its luminaires as designed for the
   whole-room task area): invrad's exact model (``RoomModel.exact``: direct light with
   shadows and radiosity) against Radiance (rtrace at the band's points only, on copies of
   the round's octree and ambient cache: ``out/radjobs_bg/<room>/invrad``, copied from
   ``--from`` (default ``/work/wt9-design/out/radjobs``; never written there), the same
   ``AMBIENT`` settings), both maintained (x MF); Em, U0, the default requirement (1/3 of
   the surroundings' Em, U0 0.10) and each engine's verdict.

3. **Designed for a task area set in** (``--design ROOM:MARGIN ...``): the room designed
   with its task area ``MARGIN`` m in from the walls (the background one more requirement)
   and the design judged by Radiance on every item (``bench_design_radiance``'s judgement,
   in ``out/radjobs_bg/<room>_in<MARGIN>``).

Run: ``.venv/bin/python bench/bench_background_radiance.py [--from DIR] [room ...]`` or
``... --design lab:2``.
A room whose traced job does not hold the pickled design's luminaires is skipped (said so).

Measured 2026-11-26 (round 10, shared 2-core machine at load 2-3; round 9's designs and
their octrees and ambient caches; maintained lux, MF 0.8):

==========  ========  =============  =======  ========  ==============  ==============  =====
room        set in    band (m)       points   m2        invrad Em/U0    Radiance Em/U0  ratio
==========  ========  =============  =======  ========  ==============  ==============  =====
L office    2.5 m     0 - 2.0          74      67.2     436.2 / 0.48    433.4 / 0.48    1.007
classroom   1.5 m     0 - 1.0         204      38.0     388.4 / 0.38    383.4 / 0.38    1.013
L corridor  -         -                -        -       (legs 1.8 m wide: no task area set in)
meeting     1.5 m     0 - 1.0          56      14.0     389.6 / 0.52    388.6 / 0.52    1.002
lab         3.0 m     0 - 2.5          80      44.8     444.6 / 0.46    444.5 / 0.46    1.000
hall        4.0 m     0.5 - 3.5        96     145.5     291.3 / 0.61    291.5 / 0.61    0.999
==========  ========  =============  =======  ========  ==============  ==============  =====

As designed (task areas the rooms less 0.5 m) none of the six rooms has a background area.
Set in, every design meets the default (100 lx, the hall 66.7 lx; U0 0.10) by both engines
with a wide margin (the light that serves the whole-room task area spills onto the band);
invrad's model and Radiance agree within 1.3 % on Em and 0.01 on U0. Radiance took 0-5 s
per room (the band's points interpolate the round's ambient cache). The analytic band of
the hall (19 x 11 less 13 x 5 = 144 m2) against the grid's weights: 145.5 m2.

Designed for a task area set in (``--design``; same machine, load 4-5), judged by
Radiance on every item (maintained; required in brackets):

* lab, task area 2 m in (4 x 2 m; background 0-1.5 m from the walls): invrad 153.7 W
  (the whole-room task area: 238.7 W), 23 positions of a 9 x 7 grid, 56 CPU s. Its own
  model: Em 505 / U0 0.77, surroundings 368 / 0.66, background 198 / 0.44, walls
  118 / 0.40, ceiling 55 / 0.68, UGR 18.9. Radiance (traced in 150 s): Em 506 / 0.77
  (500 / 0.60), surroundings 368 / 0.65 (300 / 0.40), background 198 / 0.44 (100 / 0.10),
  walls 118 / 0.40 (75 / 0.10), ceiling 54 / 0.70 (50 / 0.10), UGR 18.9 (19): compliant.
* hall, task area 4 m in (12 x 4 m; background 0.5-3.5 m from the walls, 96 points):
  invrad 585.1 W (whole room: 878.9 W), a 3 x 4 grid, 51 CPU s. Its own model: Em
  312 / 0.76, surroundings 271 / 0.71, background 181 / 0.35, walls 68 / 0.23, ceiling
  30 / 0.51, UGR 21.9. Radiance (57 s): Em 312.0 / 0.76 (300 / 0.60), surroundings
  271 / 0.71 (200 / 0.40), background 181 / 0.35 (66.7 / 0.10), walls 68 / 0.23
  (50 / 0.10), ceiling 30.2 / 0.50 (30 / 0.10), UGR 21.9 (22): compliant.
* L office, task area 2.5 m in (background 0-2 m from the walls, 74 points): invrad
  219.2 W (whole room: 392.7 W), one grid per rectangle, 198 CPU s. Its own model: Em
  505 / 0.81, surroundings 353 / 0.41, background 198 / 0.47, walls 115 / 0.50, ceiling
  51 / 0.69, UGR 18.9. Radiance (118 s): Em 501.9 / 0.81 (500 / 0.60), surroundings
  352 / 0.41 (300 / 0.40), background 198 / 0.48 (100 / 0.10), walls 114 / 0.50
  (75 / 0.10), ceiling 49.8 / 0.69 (50 / 0.10: met within the judge's 0.5 lx, Radiance's
  ceiling 2.4 % under invrad's, as in bench_design_radiance), UGR 18.8 (19): compliant.

The background binds in none of them (about twice its minimum): light that meets the task
area and the surroundings from a ceiling grid spills that far; its U0 (0.35-0.48) is the
item's closest.
"""
import os
import pickle
import shutil
import subprocess
import sys
import time

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
sys.path.insert(0, os.path.dirname(HERE))

import bench_design_radiance as B  # noqa: E402
from invrad_wb.core.design.background import (background_grid,  # noqa: E402
                                              background_requirement, band_limits)
from invrad_wb.core.design.evaluate import RoomModel  # noqa: E402
from invrad_wb.core.design.room import DesignRoom  # noqa: E402
from invrad_wb.core.design.search import Metrics  # noqa: E402
from invrad_wb.errors import SceneError  # noqa: E402

OUT = os.path.join(os.path.dirname(HERE), "out", "radjobs_bg")
#: border zones tried for a task area set in (m), the largest that leaves one first
MARGINS = (4.0, 3.5, 3.0, 2.5, 2.0, 1.5, 1.0)


def _task_set_in(droom, req):
    """(margin, band) of the largest border zone of :data:`MARGINS` that leaves a task
    area and a background, or (None, None)."""
    for m in MARGINS:
        try:
            droom.grid(req.height_m, m)
        except SceneError:
            continue
        band = background_grid(droom, req.height_m, m)
        if band is not None:
            return m, band
    return None, None


def _job_positions(job):
    """Luminaire positions (k, 3) of a traced job's scene.rad (1 mm off their mount)."""
    pos = []
    with open(os.path.join(job, "scene.rad")) as fh:
        for ln in fh:
            if ln.startswith("!xform -n L"):
                w = ln.split()
                i = w.index("-t")
                pos.append([float(x) for x in w[i + 1:i + 4]])
    return np.array(pos).reshape(-1, 3)


def main(names, source):
    os.makedirs(OUT, exist_ok=True)
    cat = B.catalogue(OUT)
    b, env = B._radiance()
    env = dict(env, RADBIN=b)
    print(f"Radiance: {' '.join(B.AMBIENT)}; background judged at the band's points only")
    for name in names:
        build, room = B.ROOMS[name]
        scene = build()
        spec = B.room_spec(cat, room)
        rs = spec.room_spec(0)
        req = rs.work_plane
        droom = DesignRoom(scene, 0)
        mf = spec.maintenance_factor
        band = background_grid(droom, req.height_m, req.margin_m)
        print(f"{name}: as designed (task area the room less {req.margin_m:g} m):"
              + (" no background area (the 0.5 m surroundings fill the border)"
                 if band is None else f" a background of {band[2].sum():.1f} m2 (!)"))
        m, band = _task_set_in(droom, req)
        if band is None:
            print(f"{name}: no task area set in up to {MARGINS[0]:g} m leaves a background"
                  " (too narrow): skipped")
            continue
        src = os.path.join(source, name, "invrad")
        pkl = os.path.join(source, name, "invrad.pkl")
        if not (os.path.exists(os.path.join(src, "scene.oct")) and os.path.exists(pkl)):
            print(f"{name}: no traced invrad design in {source}: skipped")
            continue
        with open(pkl, "rb") as fh:
            lums = pickle.load(fh)["lums"]
        jp = _job_positions(src)
        lp = np.array([lum.position + 0.001 * lum.normal for lum in lums])
        if len(jp) != len(lp) or np.abs(np.sort(jp, axis=0) - np.sort(lp, axis=0)).max() > 1e-3:
            print(f"{name}: its traced job holds another design than {pkl}: skipped")
            continue
        job = os.path.join(OUT, name, "invrad")
        if not os.path.isdir(job):
            shutil.copytree(src, job)
        P, N, W = band
        q = background_requirement(None, req.lux)
        d0, d1 = band_limits(m)
        # invrad's exact model of the band with the design's luminaires
        t = time.perf_counter()
        wp, _ = droom.grid(req.height_m, m)
        model = RoomModel(scene, droom, wp, mf, surfaces={"background": band})
        lux, direct = model.exact(lums)
        em_i, _, u0_i = Metrics.of(lux, direct, model.layout).surfaces["background"]
        t_i = time.perf_counter() - t
        # Radiance at the same points, on a copy of the round's octree and ambient cache
        out = os.path.join(job, f"bg_{m:g}.out")
        if not os.path.exists(out):
            with open(os.path.join(job, f"bg_{m:g}.txt"), "w") as fh:
                fh.write(B._rays(P, N))
            t = time.perf_counter()
            with open(os.path.join(job, f"bg_{m:g}.txt")) as fi, open(out + ".tmp", "w") as fo:
                subprocess.run([os.path.join(b, "rtrace"), "-I", "-h", "-dj", "0", "-ds",
                                "0.05", *B.AMBIENT, "scene.oct"], cwd=job, env=env,
                               stdin=fi, stdout=fo, check=True)
            os.replace(out + ".tmp", out)
            print(f"{name}: {len(P)} background points traced in"
                  f" {time.perf_counter() - t:.0f} s", flush=True)
        e = mf * B._read_lux(out)
        em_r = float(np.sum(W * e) / W.sum())
        u0_r = float(e.min() / em_r)
        ok = lambda em, u0: em >= q.lux - 0.5 and u0 >= q.u0 - 0.005   # noqa: E731
        print(f"{name}: task area {m:g} m in, background {d0:g}-{d1:g} m from the walls,"
              f" {len(P)} points, {W.sum():.1f} m2; required Em >= {q.lux:.4g} lx,"
              f" U0 >= {q.u0:.2f}: invrad Em {em_i:.1f} U0 {u0_i:.2f}"
              f" ({'pass' if ok(em_i, u0_i) else 'FAIL'}, {t_i:.0f} s); Radiance"
              f" Em {em_r:.1f} U0 {u0_r:.2f} ({'pass' if ok(em_r, u0_r) else 'FAIL'});"
              f" invrad / Radiance Em {em_i / em_r:.3f}", flush=True)


def design_set_in(name, margin):
    """Design room ``name`` for a task area ``margin`` m in from its walls (its background
    a requirement like every other item) and judge the design by Radiance on every item
    (the whole judgement of ``bench_design_radiance``, in ``out/radjobs_bg/<name>_in<m>``)."""
    from invrad_wb.core.design.design import design_room
    from invrad_wb.core.model.photometry import read_photometry
    cat = B.catalogue(OUT)
    phot_paths = {e["name"]: e["photometry"] for e in cat}
    phot = {n: read_photometry(p) for n, p in phot_paths.items()}
    build, room = B.ROOMS[name]
    scene = build()
    spec = B.spec_from_dict({"maintenance_factor": 0.8, "catalogue": cat, "rooms": {
        "0": dict(room, work_plane=dict(room["work_plane"], height_m=0.75, margin_m=margin))}})
    job = os.path.join(OUT, f"{name}_in{margin:g}", "invrad")
    cache = job + ".pkl"
    if os.path.exists(cache):
        with open(cache, "rb") as fh:
            r = pickle.load(fh)
    else:
        t = time.process_time()
        rd = design_room(scene, spec, 0, photometry=phot)
        m, su = rd.metrics, rd.metrics.surfaces
        r = dict(lums=rd.luminaires, watts=rd.watts, s=time.process_time() - t,
                 compliant=rd.compliant,
                 own=f"{m.em:.0f}/{m.u0:.2f} " + " ".join(
                     f"{k} {su[k][0]:.0f}/{su[k][2]:.2f}" for k in su)
                 + f" UGR {'-' if rd.ugr is None else round(rd.ugr, 1)}",
                 desc=rd.candidate.geom.describe())
        if os.path.isdir(job):
            shutil.rmtree(job)
        r["plan"] = B.judge_prepare(scene, spec, r["lums"], job, phot_paths)
        with open(cache, "wb") as fh:
            pickle.dump(r, fh)
    print(f"{name}, task area {margin:g} m in: invrad {r['watts']:.1f} W, {r['desc']},"
          f" compliant by its own model {r['compliant']} ({r['own']}; {r['s']:.0f} CPU s)",
          flush=True)
    if not os.path.exists(os.path.join(job, "direct.out")):
        b, env = B._radiance()
        t = time.perf_counter()
        subprocess.run(["sh", os.path.join(job, "run.sh")], env=dict(env, RADBIN=b),
                       check=True)
        print(f"{name}: traced in {time.perf_counter() - t:.0f} s", flush=True)
    rad = B.judge_finish(job, r["plan"], spec, r["lums"])
    rs = B.judge_grids(scene, spec)[0]
    ok = B.verdict(rad, rs)
    items = ("surroundings", "background", "walls", "ceiling")
    fails = [k for k, v in ok.items() if not v]
    print(f"{name}: Radiance Em {rad['em']:.0f} U0 {rad['u0']:.2f}, "
          + ", ".join(f"{k} {B._fmt(rad, k)} (>= {rs.surfaces[k].lux:.4g}"
                      f"/{rs.surfaces[k].u0:.2f})" for k in items if k in rad)
          + f", UGR {'-' if rad['ugr'] is None else round(rad['ugr'], 1)}"
          + (": compliant" if not fails else ": FAILS " + ",".join(fails)), flush=True)


if __name__ == "__main__":
    args = sys.argv[1:]
    source = "/work/wt9-design/out/radjobs"
    if "--from" in args:
        i = args.index("--from")
        source = args[i + 1]
        del args[i:i + 2]
    if "--design" in args:          # --design ROOM:MARGIN ...
        for a in args[args.index("--design") + 1:]:
            n, m = a.split(":")
            design_set_in(n, float(m))
    else:
        main(args or list(B.ROOMS), source)
