"""Radiance (``pyradiance``'s binaries) as the independent judge of designed rooms: what the
tests of ``test_design_radiance.py`` share.

A scene's faces become Radiance polygons of plastic at their reflectances; each luminaire
is its type's IES LM-63 file turned into a Radiance luminaire by ``ies2rad`` (its luminous
rectangle a ``light`` polygon with the file's candela distribution, scaled to the
luminaire's output), placed 1 mm below its mount. Illuminance comes from ``rtrace -I``
(lux = 179 x the mean of the RGB irradiance), luminance from ``rtrace`` (cd/m^2 = 179 x
the radiance), a fisheye from ``rpict -vta``. Written for these tests, after
``bench/bench_design_radiance.py`` (which tests must not import); it knows nothing of
invrad's light models.
"""
import math
import os
import subprocess

import numpy as np

#: Radiance's luminous efficacy of its white light (lm/W): lux = 179 x irradiance
WHITE_EFFICACY = 179.0


def radiance_binaries():
    """(bin folder, environment) of pyradiance's Radiance, or None where pyradiance or its
    binaries are missing."""
    try:
        import pyradiance
    except ImportError:
        return None
    base = os.path.dirname(pyradiance.__file__)
    b, lib = os.path.join(base, "bin"), os.path.join(base, "lib")
    if not all(os.path.exists(os.path.join(b, x))
               for x in ("rtrace", "oconv", "ies2rad", "rpict", "evalglare")):
        return None
    env = dict(os.environ, RAYPATH=f".:{lib}", PATH=b + os.pathsep + os.environ["PATH"])
    return b, env


#: direct light: every source tested for shadow at every point (``-dt 0 -dc 1``; Radiance's
#: default -dt 0.03 leaves the sources of least potential untested and guesses their
#: visibility: with 13 dimmed panels in an L with a column that put the work plane's
#: interreflected light 4.4 % low, 62.3 against 64.8 lx at -ab 6 -ad 512, where the design
#: model has 65.2), the area sources split finely (-ds 0.02), no jitter
DIRECT = ["-dt", "0", "-dc", "1", "-dj", "0", "-ds", "0.02"]

#: gamma angles (degrees) of the IES files written here
GAMMAS = [2.5 * i for i in range(73)]


def write_ies(path, name, flux_lm, exponent, size_m):
    """An IES LM-63-2002 file, type C, one C plane (rotationally symmetric):
    I = F (n + 1) / (2 pi) cos^n(gamma), a luminous rectangle of ``size_m`` (width, length)
    metres (units 2)."""
    cd = [flux_lm * (exponent + 1) / (2 * math.pi)
          * max(math.cos(math.radians(g)), 0.0) ** exponent for g in GAMMAS]
    head = ["IESNA:LM-63-2002", f"[TEST] invrad test {name}", "[MANUFAC] invrad tests",
            f"[LUMCAT] {name}", f"[LUMINAIRE] {name}", "TILT=NONE",
            f"1 {flux_lm:g} 1 {len(GAMMAS)} 1 1 2 {size_m[0]:g} {size_m[1]:g} 0",
            "1.0 1.0 10"]
    body = [" ".join(f"{x:g}" for x in GAMMAS), "0", " ".join(f"{v:.4f}" for v in cd)]
    with open(path, "w") as fh:
        fh.write("\n".join(head + body) + "\n")


class RadianceRoom:
    """A room and its luminaires in Radiance (folder ``folder``: scene.rad, scene.oct).

    Parameters
    ----------
    scene : invrad Scene (vertices, faces, face_reflectance, face_virtual)
    luminaires : list of Luminaire, each with ``extra['type']`` naming its catalogue entry
    ies : dict type -> (IES path, the flux (lm) the file describes)
    """

    def __init__(self, folder, scene, luminaires, ies, ambient):
        found = radiance_binaries()
        if found is None:
            raise RuntimeError("pyradiance's Radiance binaries are missing")
        self.bin, self.env = found
        self.folder, self.ambient = folder, list(ambient)
        lines = []
        rho = np.round(scene.face_reflectance, 3)
        for r in np.unique(rho):
            lines.append(f"void plastic m{int(r * 1000)} 0 0 5 {r} {r} {r} 0 0")
        tri = scene.vertices[scene.faces]
        for i in np.flatnonzero(~scene.face_virtual):
            lines.append(f"m{int(rho[i] * 1000)} polygon f{i} 0 0 9 "
                         + " ".join(f"{x:.6f}" for x in tri[i].reshape(-1)))
        made = {}
        self.light_names = []          # each luminaire's light material (rtrace -om)
        for k, lum in enumerate(luminaires):
            if np.linalg.norm(lum.normal - [0.0, 0.0, -1.0]) > 1e-6:
                raise ValueError("only downward luminaires (ies2rad's own frame)")
            path, file_flux = ies[lum.extra["type"]]
            mult = lum.flux_lm / file_flux
            key = (lum.extra["type"], round(mult, 6))
            if key not in made:
                stem = f"lum{len(made)}"
                self._run("ies2rad", "-dm", "-m", f"{mult:.6f}", "-l", folder, "-o", stem,
                          path)
                made[key] = stem
            self.light_names.append(f"{made[key]}_light")
            p = lum.position + 0.001 * lum.normal            # 1 mm below the mount
            lines.append(f"!xform -n L{k} -t {p[0]:.5f} {p[1]:.5f} {p[2]:.5f}"
                         f" {made[key]}.rad")
        with open(os.path.join(folder, "scene.rad"), "w") as fh:
            fh.write("\n".join(lines) + "\n")
        with open(os.path.join(folder, "scene.oct"), "wb") as fh:
            subprocess.run([os.path.join(self.bin, "oconv"), "-f", "scene.rad"],
                           cwd=folder, env=self.env, stdout=fh, check=True)

    def _run(self, tool, *args, stdin=None):
        return subprocess.run([os.path.join(self.bin, tool), *args], cwd=self.folder,
                              env=self.env, input=stdin, capture_output=True, text=True,
                              check=True).stdout

    def _rtrace(self, opts, points, dirs):
        rays = "".join(f"{p[0]:.6f} {p[1]:.6f} {p[2]:.6f} {d[0]:.6f} {d[1]:.6f} {d[2]:.6f}\n"
                       for p, d in zip(points, dirs))
        return self._run("rtrace", "-h", *DIRECT, *opts, "scene.oct",
                         stdin=rays).splitlines()

    @staticmethod
    def _photopic(lines):
        rgb = np.array([[float(x) for x in ln.split()[:3]] for ln in lines if ln.strip()])
        return WHITE_EFFICACY * rgb.mean(axis=1) if len(rgb) else np.zeros(0)

    def illuminance(self, points, normals, interreflected=True):
        """(k,) lux at receivers facing ``normals`` (new installation): with the ambient
        settings (one cache, ``scene.amb``), or the direct light alone (``-ab 0``)."""
        opts = (["-I", *self.ambient, "-af", "scene.amb"] if interreflected
                else ["-I", "-ab", "0"])
        return self._photopic(self._rtrace(opts, points, normals))

    def luminance_seen(self, eye, targets):
        """(luminance cd/m^2 (k,), modifier hit (k,)) of the rays from ``eye`` through
        ``targets`` (k, 3): direct only (a luminaire's light is its own luminance)."""
        eye = np.asarray(eye, dtype=np.float64)
        d = np.asarray(targets, dtype=np.float64) - eye
        d /= np.linalg.norm(d, axis=1)[:, None]
        out = self._rtrace(["-ab", "0", "-ovm"], np.tile(eye, (len(d), 1)), d)
        lum, mods = [], []
        for ln in out:
            f = ln.split()
            lum.append(WHITE_EFFICACY * (float(f[0]) + float(f[1]) + float(f[2])) / 3.0)
            mods.append(f[3] if len(f) > 3 else "")
        return np.array(lum), mods

    def fisheye(self, name, eye, view, pixels):
        """Render an angular fisheye (``-vta``, 180 x 180 degrees) of ``pixels`` square from
        ``eye`` along ``view``, with the ambient settings and their cache; returns the
        picture's path."""
        pic = os.path.join(self.folder, name)
        vu = "0 0 1"
        args = ["-vta", "-vp", *[f"{x:.6f}" for x in eye], "-vd",
                *[f"{x:.6f}" for x in view], "-vu", *vu.split(), "-vh", "180", "-vv", "180",
                "-x", str(pixels), "-y", str(pixels), "-ps", "1", "-pj", "0", *DIRECT,
                *self.ambient, "-af", "scene.amb", "scene.oct"]
        with open(pic, "wb") as fh:
            subprocess.run([os.path.join(self.bin, "rpict"), *args], cwd=self.folder,
                           env=self.env, stdout=fh, check=True)
        return pic

    def evalglare(self, pic, threshold_cd_m2):
        """evalglare's detailed figures of a fisheye picture, glare sources being the pixels
        over ``threshold_cd_m2`` (no peak extraction): dict name -> value (dgp, E_v,
        lum_backg, E_v_dir, ugr, ...)."""
        out = self._run("evalglare", "-vta", "-vh", "180", "-vv", "180", "-b",
                        f"{threshold_cd_m2:g}", "-x", "-d", pic)
        return parse_evalglare(out)


def parse_evalglare(text):
    """dict of the detailed output's ``name,name,...: value value ...`` line."""
    for ln in text.splitlines():
        if ln.startswith("dgp,") and ":" in ln:
            names, values = ln.split(":", 1)
            vals = values.split()
            return {n.strip(): float(v) for n, v in zip(names.split(","), vals)}
    raise ValueError(f"no detailed glare line in evalglare's output:\n{text}")


def polygon_solid_angle(eye, corners):
    """Solid angle (sr) a planar polygon ``corners`` (k, 3) subtends at ``eye`` (3,): the
    sum over a fan of triangles of Van Oosterom and Strackee's formula."""
    r = np.asarray(corners, dtype=np.float64) - np.asarray(eye, dtype=np.float64)
    total = 0.0
    for i in range(1, len(r) - 1):
        a, b, c = r[0], r[i], r[i + 1]
        la, lb, lc = np.linalg.norm(a), np.linalg.norm(b), np.linalg.norm(c)
        num = float(a @ np.cross(b, c))
        den = la * lb * lc + float(a @ b) * lc + float(a @ c) * lb + float(b @ c) * la
        total += 2.0 * math.atan2(num, den)
    return abs(total)


def guth_position_index(eye, view, target):
    """Guth's position index of a source at ``target`` seen from ``eye`` looking along the
    horizontal ``view`` (IESNA Lighting Handbook fit; CIE 117): tau the angle between the
    vertical plane through the line of sight and the plane through it and the source,
    sigma the angle between the line of sight and the source (degrees)."""
    v = np.asarray(view, dtype=np.float64)
    v = v / np.linalg.norm(v)
    d = np.asarray(target, dtype=np.float64) - np.asarray(eye, dtype=np.float64)
    x = float(d @ v)                                   # ahead
    side = np.cross([0.0, 0.0, 1.0], v)
    y, z = float(d @ side), float(d[2])                 # across, up
    sigma = math.degrees(math.atan2(math.hypot(y, z), x))
    tau = math.degrees(math.atan2(abs(y), z))
    ln_p = ((35.2 - 0.31889 * tau - 1.22 * math.exp(-2.0 * tau / 9.0)) * 1e-3 * sigma
            + (21.0 + 0.26667 * tau - 0.002963 * tau * tau) * 1e-5 * sigma * sigma)
    return math.exp(ln_p)
