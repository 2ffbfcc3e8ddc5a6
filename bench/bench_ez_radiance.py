"""Cylindrical illuminance Ez against Radiance (pyradiance's rtrace): prints the figures.

A 5 x 4 x 2.5 m box (reflectance 0.5), one 2000 lm lambertian downlight in the middle of
the ceiling (a 3 cm Radiance ``light`` disc, 179 lm/W); Ez at six task-area points at
1.2 m: invrad's (core/design/cylindrical.py, mf 1) against Radiance's vertical irradiance
in 16 horizontal directions averaged, direct alone (-ab 0) and with interreflection
(-ab 5). Measured: direct 0.994, total 1.005 (mean ratio invrad / Radiance).

Run: PYTHONPATH=. .venv/bin/python bench/bench_ez_radiance.py   (about 1 min on 2 cores)
"""
import os
import subprocess
import sys
import tempfile
from types import SimpleNamespace

import numpy as np

try:
    import pyradiance
except ImportError:
    sys.exit("bench/bench_ez_radiance.py needs pyradiance (pip install pyradiance)")
_here = os.path.dirname(pyradiance.__file__)
T = SimpleNamespace(BIN=os.path.join(_here, "bin"), LIB=os.path.join(_here, "lib"),
                    SIZE=(5.0, 4.0, 2.5), RHO=0.5, FLUX=2000.0, DISC_R=0.03,
                    AMBIENT=["-ab", "5", "-ad", "1024", "-as", "256", "-aa", "0.1", "-ar",
                             "64", "-lw", "1e-4"])
from invrad_wb.core.synthetic import generate
from invrad_wb.core.model.scene import Scene
from invrad_wb.core.model.luminaires import Luminaire
from invrad_wb.core.design.room import DesignRoom
from invrad_wb.core.design.evaluate import RoomModel
from invrad_wb.core.design.cylindrical import CylindricalGrid
sc = generate.box_room(size=T.SIZE, cell=0.3)
sc = Scene(sc.vertices, sc.faces, face_room=sc.face_room,
           face_reflectance=np.full(len(sc.faces), T.RHO), check_winding=False)
dr = DesignRoom(sc, 0)
wp, _ = dr.grid(0.75, 0.5)
pts, _ = dr.grid(1.2, 0.5)
pts = pts[np.linspace(0, len(pts) - 1, 6).astype(int)]
model = RoomModel(sc, dr, wp, 1.0, "numpy")
cyl = CylindricalGrid(model, pts, {"lux": 1, "u0": 0, "height_m": 1.2})
pos = [2.5, 2.0, 2.5]
lum = Luminaire(pos, [0, 0, -1], T.FLUX)
dz, dh = cyl.direct([lum]); iz, ih = cyl.indirect([lum])
# Radiance: vertical irradiance in 16 horizontal directions, averaged
ND = 16
a = 2 * np.pi * np.arange(ND) / ND
env = dict(os.environ, RAYPATH=f".:{T.LIB}", PATH=T.BIN + os.pathsep + os.environ["PATH"])
tmp = tempfile.mkdtemp()
c = np.asarray(pos, float) + np.array([0, 0, -1.0]) * 0.002
L = T.FLUX / (179.0 * np.pi * np.pi * T.DISC_R ** 2)
box = subprocess.run([os.path.join(T.BIN, "genbox"), "grey", "room", *map(str, T.SIZE), "-i"],
                     capture_output=True, text=True, env=env, check=True).stdout
rad = os.path.join(tmp, "scene.rad")
open(rad, "w").write(f"void light lum 0 0 3 {L} {L} {L}\n"
                     f"lum ring lamp 0 0 8 {c[0]} {c[1]} {c[2]} 0 0 -1 0 {T.DISC_R}\n"
                     f"void plastic grey 0 0 5 {T.RHO} {T.RHO} {T.RHO} 0 0\n" + box)
oct_ = os.path.join(tmp, "scene.oct")
with open(oct_, "wb") as fh:
    subprocess.run([os.path.join(T.BIN, "oconv"), rad], stdout=fh, env=env, check=True)
rays = "".join(f"{p[0]} {p[1]} {p[2]} {np.cos(t)} {np.sin(t)} 0\n" for t in a for p in pts)
for name, amb in (("direct", ["-ab", "0"]), ("total", T.AMBIENT)):
    out = subprocess.run([os.path.join(T.BIN, "rtrace"), "-I", "-h", *amb, "-dj", "0", "-ds", "0.02", oct_],
                         input=rays, capture_output=True, text=True, env=env, check=True, cwd=tmp).stdout
    e = 179.0 * np.array([[float(x) for x in l.split()[:3]] for l in out.strip().splitlines()]).mean(1)
    ez_r = e.reshape(ND, len(pts)).mean(0)
    mine = dz if name == "direct" else dz + iz
    print(name, "radiance", np.round(ez_r, 1), "invrad", np.round(mine, 1),
          "mean ratio %.3f" % (mine.mean() / ez_r.mean()))
