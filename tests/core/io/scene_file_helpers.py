"""What the scene-file tests share: PLY files written by hand (independently of the
reader under test), a box of quads, images, scenes with every kind of value."""
import glob
import os

import numpy as np
import pytest

from invrad_wb.core.synthetic import generate
from invrad_wb.core.model.scene import Scene

trimesh = pytest.importorskip("trimesh")

NP_TYPES = {"char": "i1", "uchar": "u1", "short": "i2", "ushort": "u2", "int": "i4",
            "uint": "u4", "float": "f4", "double": "f8"}


def make_ply(path, vprops, vrows, fprops=(), frows=(), fmt="ascii", count_type="uchar",
             index_type="int", vertex_count=None, index_name="vertex_indices"):
    """Hand-write a PLY independently of the module under test.

    vprops: [(name, type)], vrows: rows of values; fprops: extra scalar face properties,
    frows: [(indices, *extra values)]. In ASCII files a str value is written verbatim.
    """
    lines = ["ply", f"format {fmt} 1.0", "comment test file"]
    lines.append(f"element vertex {len(vrows) if vertex_count is None else vertex_count}")
    lines += [f"property {t} {n}" for n, t in vprops]
    lines.append(f"element face {len(frows)}")
    lines.append(f"property list {count_type} {index_type} {index_name}")
    lines += [f"property {t} {n}" for n, t in fprops]
    lines.append("end_header")
    head = ("\n".join(lines) + "\n").encode("ascii")
    if fmt == "ascii":
        def txt(v):
            return v if isinstance(v, str) else repr(float(v)) if isinstance(v, float) \
                else str(v)
        body = [" ".join(txt(v) for v in row) for row in vrows]
        body += [" ".join([str(len(r[0]))] + [str(i) for i in r[0]] + [txt(v) for v in r[1:]])
                 for r in frows]
        data = head + ("\n".join(body) + "\n").encode("ascii")
    else:
        e = "<" if fmt == "binary_little_endian" else ">"

        def pack(v, t):
            return np.array(v, dtype=e + NP_TYPES[t]).tobytes()
        data = head
        for row in vrows:
            data += b"".join(pack(v, t) for v, (_, t) in zip(row, vprops))
        for r in frows:
            data += pack(len(r[0]), count_type) + pack(list(r[0]), index_type)
            data += b"".join(pack(v, t) for v, (_, t) in zip(r[1:], fprops))
    with open(path, "wb") as fh:
        fh.write(data)
    return str(path)


XYZ = [("x", "double"), ("y", "double"), ("z", "double")]


TRIANGLE = [(0.0, 0.0, 0.0), (1.0, 0.0, 0.0), (0.0, 1.0, 0.0)]


def quad_box(size=(4.0, 3.0, 2.5)):
    """A closed box room of 8 corners: 5 quads facing inward plus a floor of 2 triangles."""
    sx, sy, sz = size
    verts = np.array([(x * sx, y * sy, z * sz) for z in (0, 1) for y in (0, 1) for x in (0, 1)])
    centre = verts.mean(0)
    polys = [[0, 1, 3], [0, 3, 2],                       # floor as two triangles
             [4, 5, 7, 6], [0, 1, 5, 4], [2, 3, 7, 6], [0, 2, 6, 4], [1, 3, 7, 5]]
    out = []
    for p in polys:
        pts = verts[p]
        n = np.cross(pts[1] - pts[0], pts[2] - pts[0])
        out.append(p if n @ (centre - pts.mean(0)) > 0 else p[::-1])
    return verts, out


def write_image(path, pixels, fmt):
    oiio = pytest.importorskip("OpenImageIO")
    pixels = np.asarray(pixels)
    if pixels.ndim == 2:  # OIIO's write_image misreads 2-D arrays: give (h, w, 1)
        pixels = pixels[:, :, None]
    pixels = np.ascontiguousarray(pixels)
    h, w, nc = pixels.shape
    out = oiio.ImageOutput.create(str(path))
    assert out is not None, oiio.geterror()
    assert out.open(str(path), oiio.ImageSpec(w, h, nc, fmt)), out.geterror()
    assert out.write_image(pixels), out.geterror()
    out.close()
    return str(path)


def rich_scene():
    """Two rooms, varied reflectance, per-vertex targets with NaN (no target) and 0 (dark)."""
    base, _ = generate.floor_of_rooms(rooms=((3.0, 2.0), (2.0, 2.0)), cell=0.7)
    rng = np.random.default_rng(1)
    rho = rng.uniform(0.05, 0.95, len(base.faces))
    lux = rng.uniform(0, 800, len(base.vertices))
    lux[::7] = np.nan
    lux[3::11] = 0.0
    return Scene(base.vertices, base.faces, vertex_lux=lux, face_room=base.face_room,
                 face_reflectance=rho)


def assert_same_scene(a, b):
    np.testing.assert_array_equal(a.vertices, b.vertices)
    np.testing.assert_array_equal(a.faces, b.faces)
    np.testing.assert_array_equal(a.face_room, b.face_room)
    np.testing.assert_array_equal(a.face_reflectance, b.face_reflectance)


def no_temp_files(folder):
    return not glob.glob(os.path.join(str(folder), ".invrad-*"))


def bary_of(tri2d, p):
    a, b, c = tri2d
    m = np.array([b - a, c - a]).T
    s, t = np.linalg.solve(m, p - a)
    return np.array([1 - s - t, s, t])


def export_obj(scene, path):
    trimesh.Trimesh(scene.vertices, scene.faces, process=False).export(str(path))
    return str(path)


def floor_with_uv(tmp_path, name="floor.obj"):
    """A 4 m x 2 m floor with u = x / 4, v = y / 2 (glTF files are written Y-up)."""
    v = np.array([[0, 0, 0], [4, 0, 0], [4, 2, 0], [0, 2, 0.0]])
    f = np.array([[0, 1, 2], [0, 2, 3]])
    uv = v[:, :2] / [4.0, 2.0]
    if name.endswith(".glb"):
        v = np.stack([v[:, 0], v[:, 2], -v[:, 1]], axis=1)
    mesh = trimesh.Trimesh(v, f, process=False, visual=trimesh.visual.TextureVisuals(uv=uv))
    path = str(tmp_path / name)
    mesh.export(path)
    return path
