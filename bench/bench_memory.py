#!/usr/bin/env python3
"""Memory budget benchmark: peak memory of locate / verify / render against what grows with a
user's numbers, and adversarial settings held under the limit.

Every run is one CLI process (``python -m invrad_wb ...``) started from a child of this
script, so that ``RUSAGE_CHILDREN`` holds exactly that run's peak resident memory. Sections:

* ``resolution``: ``locate`` on examples/office.ply at finer vote-map resolutions, with the
  canvas estimate the budget checks (:func:`invrad_wb.core.inverse.votemaps.canvas_memory`)
  against the peak above the coarsest run's (the part that grows with the pixels);
* ``mesh``: ``locate``, ``verify`` and ``render`` of the one_ceiling example meshed at
  finer cells;
* ``rooms``: ``render``, ``verify`` and ``locate`` of generated floors of N rooms (4-6 m box
  rooms, one 3000 lm downlight each, rho 0.5), with the radiosity estimate
  (:func:`invrad_wb.core.forward.render.radiosity_memory`) and whether it is computed room
  by room under the limit;
* ``luminaires``: ``render`` and ``verify`` with 1,000 to 100,000 luminaires;
* ``adversarial``: settings that ask for more than the limit (``INVRAD_MEMORY_LIMIT``,
  default 2G here): each must either be refused at once with its estimate (exit 2) or run
  with a measured peak under the limit. Prints the estimate, the limit and the peak; exits 1
  if a peak exceeds its limit.

Usage: python bench/bench_memory.py [--sections resolution mesh rooms luminaires
adversarial] [--rooms 16 64 256] [--quick] [--backend auto]
"""
import argparse
import json
import os
import re
import struct
import subprocess
import sys
import tempfile
import time
import zlib

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, ROOT)

import numpy as np  # noqa: E402

from invrad_wb.core.io.sceneio import read_scene, write_scene  # noqa: E402
from invrad_wb.core.inverse.locate import LocateSettings  # noqa: E402
from invrad_wb.core.inverse.votemaps import canvas_memory, dummy_layer_heights  # noqa: E402
from invrad_wb.core.model.memory import human, parse_size  # noqa: E402

SCENE = os.path.join(ROOT, "examples", "office.ply")
MB = 2 ** 20

# one CLI run in a child of a child: RUSAGE_CHILDREN then holds exactly that run's peak
_RUN = """
import resource, subprocess, sys
p = subprocess.run(sys.argv[1:], stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                   text=True)
err = [l for l in p.stderr.splitlines() if l.startswith("invrad: error")]
print(p.returncode, resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss)
print(err[0] if err else "")
"""


def cli(args, limit=None, backend="auto"):
    """Run ``invrad args`` in its own process: (exit status, peak bytes, error line,
    seconds)."""
    env = dict(os.environ, PYTHONPATH=ROOT)
    if limit:
        env["INVRAD_MEMORY_LIMIT"] = limit
    if backend and args[0] in ("locate", "render", "verify", "example"):
        args = list(args) + ["--backend", backend]
    t = time.perf_counter()
    out = subprocess.run([sys.executable, "-c", _RUN, sys.executable, "-m", "invrad_wb",
                          *args], capture_output=True, text=True, cwd=ROOT, env=env,
                         check=True)
    head, err = (out.stdout.split("\n") + [""])[:2]
    rc, kb = head.split()
    return int(rc), int(kb) * 1024, err.strip(), time.perf_counter() - t


def estimate_in(err):
    """The estimate a refusal gives ('would need about 5.0 TB'), in bytes, or None."""
    m = re.search(r"would need about ([0-9.]+ [KMGT]?B)", err or "")
    return parse_size(m.group(1).replace(" ", "")) if m else None


def row(*cells):
    print(" ".join(f"{c:>12}" if not isinstance(c, float) else f"{c:12.1f}" for c in cells))


# --------------------------------------------------------------------------- scenes
def floor_files(n, tmp, cell=0.25, lums_per_room=1):
    """A floor of n box rooms with rendered targets (PLY) and its luminaires (JSON)."""
    from invrad_wb.core.forward.render import render
    from invrad_wb.core.model.luminaires import Luminaire
    from invrad_wb.core.io.jsonout import write_luminaires_json
    from invrad_wb.core.synthetic import generate as g
    sizes = ((4.0, 4.0), (5.0, 4.0), (4.0, 5.0), (6.0, 4.0))
    rooms = [sizes[i % len(sizes)] for i in range(n)]
    scene, origins = g.floor_of_rooms(rooms, cell=cell, reflectance=0.5)
    lums = [Luminaire([o[0] + 0.45 * w, o[1] + 0.55 * d, 3.0], [0, 0, -1], 3000.0, room=i)
            for i, ((w, d), o) in enumerate(zip(rooms, origins))]
    path = os.path.join(tmp, f"floor{n}.ply")
    lpath = os.path.join(tmp, f"floor{n}_lums.json")
    write_scene(path, scene, lux=render(scene, lums))
    write_luminaires_json(lpath, lums)
    return path, lpath, scene


def luminaire_file(n, tmp, scene):
    """n point luminaires 5 cm below the ceiling of ``scene``'s room 0, 30000/n lm each."""
    from invrad_wb.core.model.luminaires import Luminaire
    from invrad_wb.core.io.jsonout import write_luminaires_json
    rng = np.random.default_rng(n)
    lo, hi = scene.bounds
    pos = np.c_[rng.uniform(lo[0] + 0.1, hi[0] - 0.1, n), rng.uniform(lo[1] + 0.1,
                                                                      hi[1] - 0.1, n),
                np.full(n, hi[2] - 0.05)]
    path = os.path.join(tmp, f"lums{n}.json")
    write_luminaires_json(path, [Luminaire(p, [0, 0, -1], 30000.0 / n) for p in pos])
    return path


def png_bomb(path, w, h, colour=2):
    def chunk(kind, data):
        return (struct.pack(">I", len(data)) + kind + data
                + struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF))
    ihdr = struct.pack(">IIBBBBB", w, h, 8, colour, 0, 0, 0)
    with open(path, "wb") as fh:
        fh.write(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", ihdr)
                 + chunk(b"IDAT", zlib.compress(b"\0" * 4096)) + chunk(b"IEND", b""))


# --------------------------------------------------------------------------- sections
def section_resolution(a, tmp):
    print("\n== locate on examples/office.ply against the vote-map resolution")
    scene = read_scene(SCENE)
    s = LocateSettings()
    planes = [p.index for p in scene.planes if p.room == 0 and not p.is_virtual]
    layers = len(dummy_layer_heights(scene, 0, s.dummy_spacing_m, s.dummy_count,
                                     s.dummy_lowest_m))
    row("m/pixel", "pixels", "estimate MB", "peak MB", "growth MB", "B/pixel")
    base = None
    for r in sorted(a.resolutions, reverse=True):
        est, pixels = canvas_memory(scene, 0, planes, r, layers)
        rc, peak, err, _ = cli(["locate", SCENE, "--flux", "3000", "--resolution", str(r),
                                "-o", os.path.join(tmp, "r.json")], backend=a.backend)
        base = peak if base is None else base
        growth = peak - base
        row(f"{r:.3f}", int(pixels), est / MB, peak / MB, growth / MB,
            f"{growth / pixels:.0f}" if growth > 0 else "0")


def section_mesh(a, tmp):
    print("\n== one_ceiling example against the mesh cell (locate, verify, render)")
    row("cell m", "faces", "locate MB", "verify MB", "render MB", "seconds")
    for cell in a.cells:
        scene_path = os.path.join(tmp, f"mesh{cell}.ply")
        truth = os.path.join(tmp, f"mesh{cell}.json")
        cli(["example", "one_ceiling", "--cell", str(cell), "-o", scene_path, "--truth",
             truth, "--reflectance", "0.5"], backend=a.backend)
        faces = len(read_scene(scene_path).faces)
        t = time.perf_counter()
        peaks = []
        for args in (["locate", scene_path, "--flux", "3000", "-o",
                      os.path.join(tmp, "r.json")],
                     ["verify", scene_path, "--luminaires", truth, "--report",
                      os.path.join(tmp, "rep")],
                     ["render", scene_path, "--luminaires", truth, "-o",
                      os.path.join(tmp, "out.ply")]):
            rc, peak, err, _ = cli(args, backend=a.backend)
            peaks.append(peak / MB if rc == 0 else float("nan"))
        row(f"{cell:g}", faces, *peaks, time.perf_counter() - t)


def section_rooms(a, tmp):
    from invrad_wb.core.forward.render import radiosity_memory
    from invrad_wb.core.model.memory import limit_bytes
    print(f"\n== floors of N rooms (render, verify, locate; limit {human(limit_bytes())})")
    row("rooms", "faces", "radiosity est", "by room", "render MB", "verify MB", "locate MB",
        "seconds")
    for n in a.rooms:
        path, lpath, scene = floor_files(n, tmp)
        total, rooms = radiosity_memory(scene)
        t = time.perf_counter()
        peaks = []
        runs = [["render", path, "--luminaires", lpath, "-o", os.path.join(tmp, "o.ply")],
                ["verify", path, "--luminaires", lpath, "--report",
                 os.path.join(tmp, f"rep{n}")]]
        if n <= a.locate_rooms:
            runs.append(["locate", path, "--flux", "3000", "-o", os.path.join(tmp, "r.json")])
        for args in runs:
            rc, peak, err, _ = cli(args, backend=a.backend)
            peaks.append(peak / MB if rc == 0 else float("nan"))
        peaks += [float("nan")] * (3 - len(peaks))
        row(n, len(scene.faces), human(total), "yes" if total > limit_bytes() / 2 else "no",
            *peaks, time.perf_counter() - t)


def section_luminaires(a, tmp):
    print("\n== render and verify against the luminaire count (one_ceiling, cell 0.25)")
    scene_path = os.path.join(tmp, "lumscene.ply")
    cli(["example", "one_ceiling", "--cell", "0.25", "-o", scene_path], backend=a.backend)
    scene = read_scene(scene_path)
    row("luminaires", "render MB", "verify MB", "render s")
    for n in a.luminaires:
        lpath = luminaire_file(n, tmp, scene)
        rc, peak, err, sec = cli(["render", scene_path, "--luminaires", lpath, "-o",
                                  os.path.join(tmp, "o.ply")], backend=a.backend)
        rc2, peak2, err2 = 0, float("nan") * MB, ""
        if n <= a.verify_luminaires:     # the report draws every luminaire on its images
            rc2, peak2, err2, _ = cli(["verify", scene_path, "--luminaires", lpath,
                                       "--report", os.path.join(tmp, f"lrep{n}")],
                                      backend=a.backend)
        row(n, peak / MB if rc == 0 else float("nan"),
            peak2 / MB if rc2 == 0 else float("nan"), sec)
        if rc or rc2:
            print("   ", err or err2)


def section_adversarial(a, tmp):
    limit = a.limit
    print(f"\n== adversarial settings under INVRAD_MEMORY_LIMIT={limit}")
    office = SCENE
    bomb = os.path.join(tmp, "bomb.png")
    png_bomb(bomb, 20000, 20000)
    uv = os.path.join(tmp, "uv.ply")
    from invrad_wb.core.synthetic import generate as g
    sc = g.box_room((3, 2, 2.5), cell=1.0)
    head = ("ply\nformat ascii 1.0\nelement vertex %d\nproperty float x\nproperty float y\n"
            "property float z\nproperty float s\nproperty float t\nelement face %d\n"
            "property list uchar int vertex_indices\nend_header\n"
            % (len(sc.vertices), len(sc.faces)))
    with open(uv, "w") as fh:
        fh.write(head + "".join(f"{x} {y} {z} {x / 3} {y / 2}\n" for x, y, z in sc.vertices)
                 + "".join(f"3 {i} {j} {k}\n" for i, j, k in sc.faces))
    settings = os.path.join(tmp, "fine.json")
    with open(settings, "w") as fh:
        json.dump({"pixel_m": 1e-4}, fh)
    n = max(a.rooms)
    floor, flums, _ = floor_files(n, tmp) if not os.path.exists(
        os.path.join(tmp, f"floor{n}.ply")) else (os.path.join(tmp, f"floor{n}.ply"),
                                                   os.path.join(tmp, f"floor{n}_lums.json"),
                                                   None)
    small = os.path.join(tmp, "lumscene.ply")
    if not os.path.exists(small):
        cli(["example", "one_ceiling", "--cell", "0.25", "-o", small], backend=a.backend)
    lums = luminaire_file(max(a.luminaires), tmp, read_scene(small))
    r = os.path.join(tmp, "r.json")
    cases = [
        ("locate --resolution 1e-3", ["locate", office, "--flux", "3000", "-o", r,
                                      "--resolution", "1e-3"]),
        ("locate --votes-per-m2 1e9", ["locate", office, "--flux", "3000", "-o", r,
                                       "--votes-per-m2", "1e9"]),
        ("settings pixel_m 1e-4", ["locate", office, "--flux", "3000", "-o", r,
                                   "--settings", settings]),
        ("dummy layers 1e5", ["locate", office, "--flux", "3000", "-o", r,
                              "--dummy-count", "100000", "--dummy-spacing", "1e-5"]),
        ("PNG 20000x20000 texture", ["info", uv, "--texture", bomb, "--texture-max-lux",
                                     "500"]),
        (f"render {n} rooms", ["render", floor, "--luminaires", flums, "-o",
                               os.path.join(tmp, "o.ply")]),
        (f"verify {n} rooms", ["verify", floor, "--luminaires", flums, "--report",
                               os.path.join(tmp, "arep")]),
        (f"locate {n} rooms", ["locate", floor, "--flux", "3000", "-o", r]),
        (f"render {max(a.luminaires)} lums", ["render", small, "--luminaires", lums, "-o",
                                              os.path.join(tmp, "o2.ply")]),

    ]
    row("case", "exit", "estimate", "limit", "peak MB", "seconds")
    cap = parse_size(limit)
    bad = 0
    for name, args in cases:
        rc, peak, err, sec = cli(args, limit=limit, backend=a.backend)
        est = estimate_in(err)
        ok = peak <= cap and rc in (0, 2, 3)
        bad += not ok
        print(f"{name:>28} {rc:>5} {human(est) if est else '-':>12} {human(cap):>10}"
              f" {peak / MB:10.1f} {sec:8.1f} {'ok' if ok else 'OVER THE LIMIT'}")
        if rc == 2 and err:
            print(f"{'':>28} {err[:150]}")
    return bad


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--sections", nargs="+", default=["resolution", "mesh", "rooms",
                                                      "luminaires", "adversarial"])
    ap.add_argument("--resolutions", type=float, nargs="+", default=[0.1, 0.05, 0.02, 0.01])
    ap.add_argument("--cells", type=float, nargs="+", default=[0.2, 0.1, 0.05])
    ap.add_argument("--rooms", type=int, nargs="+", default=[16, 64, 256])
    ap.add_argument("--locate-rooms", type=int, default=64,
                    help="locate only floors up to this many rooms (time)")
    ap.add_argument("--luminaires", type=int, nargs="+", default=[1000, 10000, 100000])
    ap.add_argument("--verify-luminaires", type=int, default=10000,
                    help="verify only up to this many luminaires (the report marks each on"
                         " its images: 100,000 take over 20 minutes)")
    ap.add_argument("--limit", default="2G", help="INVRAD_MEMORY_LIMIT of the adversarial runs")
    ap.add_argument("--quick", action="store_true",
                    help="small sizes only (0.1/0.05 m, cells 0.2/0.1, 4/16 rooms, 1000/10000"
                         " luminaires)")
    ap.add_argument("--backend", default="auto")
    a = ap.parse_args()
    if a.quick:
        a.resolutions, a.cells, a.rooms = [0.1, 0.05], [0.2, 0.1], [4, 16]
        a.luminaires = [1000, 10000]
    bad = 0
    with tempfile.TemporaryDirectory() as tmp:
        for s in a.sections:
            r = globals()[f"section_{s}"](a, tmp)
            bad += r or 0
    if bad:
        print(f"{bad} run(s) went over their limit")
        sys.exit(1)


if __name__ == "__main__":
    main()
