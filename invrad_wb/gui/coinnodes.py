"""The coin3d nodes of the false-colour display: the overlay's surfaces and outlines, the
legend in screen space, the room names; and the clipping planes found in a scene graph.

Runs only with FreeCAD's GUI (pivy); the numbers come from :mod:`.falsecolour`.
"""
import numpy as np

from invrad_wb.gui.falsecolour import EDGE_RGB, colours, legend_layout

#: Node names, so that a scene graph can be searched for the overlay.
OVERLAY_NAME = "InvRadFalseColour"
LEGEND_NAME = "InvRadLegend"


def _coin():
    from pivy import coin
    return coin


def _indexed(tris):
    idx = np.full((len(tris), 4), -1, dtype=np.int64)
    idx[:, :3] = tris
    return [int(i) for i in idx.reshape(-1)]


def _face_set(coin, tris, two_sided=False):
    sep = coin.SoSeparator()
    hints = coin.SoShapeHints()
    hints.vertexOrdering = coin.SoShapeHints.COUNTERCLOCKWISE
    hints.shapeType = (coin.SoShapeHints.UNKNOWN_SHAPE_TYPE if two_sided
                       else coin.SoShapeHints.SOLID)
    sep.addChild(hints)
    fs = coin.SoIndexedFaceSet()
    fs.coordIndex.setValues(0, 4 * len(tris), _indexed(tris))
    sep.addChild(fs)
    return sep


def _flat_unpickable(coin, node):
    """Clicks go through ``node``'s children to what is behind them, and they are drawn
    in their own colours, unlit."""
    pick = coin.SoPickStyle()
    pick.style = coin.SoPickStyle.UNPICKABLE
    node.addChild(pick)
    light = coin.SoLightModel()
    light.model = coin.SoLightModel.BASE_COLOR
    node.addChild(light)


def _black_text(coin, node, font_name, size):
    """Text after this in ``node`` is black, in ``font_name`` at ``size`` points."""
    mat = coin.SoMaterial()
    mat.diffuseColor = (0.0, 0.0, 0.0)
    node.addChild(mat)
    font = coin.SoFont()
    font.name = font_name
    font.size = size
    node.addChild(font)


def build_labels(labels):
    """Room names in the 3D view (screen-aligned text, drawn last and on top: the
    translucent work plane is drawn after opaque things and would cover them)."""
    coin = _coin()
    sep = coin.SoAnnotation()
    _flat_unpickable(coin, sep)
    _black_text(coin, sep, "Sans:Bold", 14)
    for name, (x, y, z) in labels:
        t = coin.SoSeparator()
        tr = coin.SoTranslation()
        tr.translation = (float(x), float(y), float(z))
        t.addChild(tr)
        txt = coin.SoText2()
        txt.string = name
        txt.justification = coin.SoText2.CENTER
        t.addChild(txt)
        sep.addChild(t)
    return sep


def _colours(coin, rgb, transparency=None):
    """A material of per-vertex colours (n, 3), all ``transparency`` if given."""
    mat = coin.SoMaterial()
    mat.diffuseColor.setValues(0, len(rgb), [tuple(map(float, c)) for c in rgb])
    if transparency is not None:
        mat.transparency.setValues(0, len(rgb), [float(transparency)] * len(rgb))
    return mat


def build_overlay(geom, work_plane_transparency=0.25):
    """The coin node of an :func:`overlay_geometry` (surfaces, work plane, outlines)."""
    coin = _coin()
    root = coin.SoSeparator()
    root.setName(OVERLAY_NAME)
    _flat_unpickable(coin, root)
    coords = coin.SoCoordinate3()
    pts = geom["points"]
    coords.point.setValues(0, len(pts), [tuple(map(float, p)) for p in pts])
    root.addChild(coords)

    faces = coin.SoSeparator()
    offset = coin.SoPolygonOffset()          # faces behind their own outlines
    offset.factor = 1.0
    offset.units = 1.0
    faces.addChild(offset)
    bind = coin.SoMaterialBinding()
    bind.value = coin.SoMaterialBinding.PER_VERTEX_INDEXED
    faces.addChild(bind)
    rgb = geom["rgb"]
    faces.addChild(_colours(coin, rgb))
    if len(geom["surfaces"]):
        faces.addChild(_face_set(coin, geom["surfaces"]))
    if len(geom["work_plane"]):
        wp = coin.SoSeparator()
        wp.addChild(_colours(coin, rgb, work_plane_transparency))
        wp.addChild(_face_set(coin, geom["work_plane"], two_sided=True))
        faces.addChild(wp)
    root.addChild(faces)

    if len(geom["edges"]):
        lines = coin.SoSeparator()
        lmat = coin.SoMaterial()
        lmat.diffuseColor = EDGE_RGB
        lines.addChild(lmat)
        style = coin.SoDrawStyle()
        style.lineWidth = 1.5
        lines.addChild(style)
        ls = coin.SoIndexedLineSet()
        e = geom["edges"]
        idx = np.full((len(e), 3), -1, dtype=np.int64)
        idx[:, :2] = e
        ls.coordIndex.setValues(0, idx.size, [int(i) for i in idx.reshape(-1)])
        lines.addChild(ls)
        root.addChild(lines)
    return root


def _text(coin, x, y, s, size=None, just=None):
    sep = coin.SoSeparator()
    tr = coin.SoTranslation()
    tr.translation = (x, y, 0.0)
    sep.addChild(tr)
    if size:
        font = coin.SoFont()
        font.name = "Sans"
        font.size = size
        sep.addChild(font)
    t = coin.SoText2()
    t.string = s
    if just == "right":
        t.justification = coin.SoText2.RIGHT
    sep.addChild(t)
    return sep


def _quad(coin, x0, y0, x1, y1, rgb, z=0.0):
    sep = coin.SoSeparator()
    m = coin.SoMaterial()
    m.diffuseColor = rgb
    sep.addChild(m)
    c = coin.SoCoordinate3()
    c.point.setValues(0, 4, [(x0, y0, z), (x1, y0, z), (x1, y1, z), (x0, y1, z)])
    sep.addChild(c)
    f = coin.SoFaceSet()
    f.numVertices.setValue(4)
    sep.addChild(f)
    return sep


def build_legend(title, vmax, swatches=(), over=False, vmin=0.0, cmap=None, fmt=None):
    """Screen-space legend: colour bar ``vmin``..``vmax`` (lux by default; ``cmap`` maps
    values to (n, 3) RGB, default viridis over 0..vmax) with ticks, swatches, title."""
    coin = _coin()
    lay = legend_layout(title, vmax, list(swatches), over, vmin=vmin, fmt=fmt)
    skip = coin.SoType.fromName("SoSkipBoundingGroup").createInstance()
    skip.setName(LEGEND_NAME)
    ann = coin.SoAnnotation()
    skip.addChild(ann)
    cam = coin.SoOrthographicCamera()
    # LEAVE_AS_IS (4): normalised [-1, 1] view coordinates; pivy 0.6 lacks the name
    cam.viewportMapping = getattr(coin.SoCamera, "LEAVE_AS_IS", 4)
    cam.position = (0.0, 0.0, 5.0)
    cam.height = 2.0
    cam.nearDistance = 1.0
    cam.farDistance = 10.0
    ann.addChild(cam)
    _flat_unpickable(coin, ann)
    px0, py0, px1, py1 = lay["panel"]
    ann.addChild(_quad(coin, px0 - 0.004, py0 - 0.006, px1 + 0.004, py1 + 0.006,
                       (0.35, 0.35, 0.35), z=-0.2))
    ann.addChild(_quad(coin, px0, py0, px1, py1, (1.0, 1.0, 1.0), z=-0.1))
    bx0, by0, bx1, by1 = lay["bar"]
    n = 48
    ys = np.linspace(by0, by1, n + 1)
    vals = np.linspace(vmin, vmax, n + 1)
    cols = cmap(vals) if cmap is not None else colours(vals, vmax, targets=False)
    bar = coin.SoSeparator()
    bind = coin.SoMaterialBinding()
    bind.value = coin.SoMaterialBinding.PER_VERTEX_INDEXED
    bar.addChild(bind)
    bar.addChild(_colours(coin, cols))
    pts = [(bx0, float(y), 0.0) for y in ys] + [(bx1, float(y), 0.0) for y in ys]
    coords = coin.SoCoordinate3()
    coords.point.setValues(0, len(pts), pts)
    bar.addChild(coords)
    idx, midx = [], []
    for i in range(n):
        quad = [i, n + 1 + i, n + 2 + i, i + 1]
        idx += quad + [-1]
        midx += [i, i, i + 1, i + 1, -1]
    fs = coin.SoIndexedFaceSet()
    fs.coordIndex.setValues(0, len(idx), idx)
    fs.materialIndex.setValues(0, len(midx), midx)
    bar.addChild(fs)
    ann.addChild(bar)
    lines = coin.SoSeparator()
    lm = coin.SoMaterial()
    lm.diffuseColor = (0.0, 0.0, 0.0)
    lines.addChild(lm)
    lpts, lidx = [(bx0, by0, 0.01), (bx1, by0, 0.01), (bx1, by1, 0.01), (bx0, by1, 0.01)], \
        [0, 1, 2, 3, 0, -1]
    for y, _ in lay["ticks"]:
        k = len(lpts)
        lpts += [(bx1, y, 0.01), (bx1 + 0.012, y, 0.01)]
        lidx += [k, k + 1, -1]
    lc = coin.SoCoordinate3()
    lc.point.setValues(0, len(lpts), lpts)
    lines.addChild(lc)
    ls = coin.SoIndexedLineSet()
    ls.coordIndex.setValues(0, len(lidx), lidx)
    lines.addChild(ls)
    ann.addChild(lines)
    text = coin.SoSeparator()
    _black_text(coin, text, "Sans", 13)
    for y, s in lay["ticks"]:
        text.addChild(_text(coin, bx1 + 0.02, y - 0.015, s))
    for y, s in lay["title"]:
        text.addChild(_text(coin, px0 + 0.012, y, s))
    for y, rgb, s in lay["swatches"]:
        ann.addChild(_quad(coin, bx0, y - 0.03, bx1, y + 0.03, rgb, z=0.0))
        text.addChild(_text(coin, bx1 + 0.02, y - 0.015, s))
    ann.addChild(text)
    return skip


def clip_planes(graphs):
    """The active clipping planes (Std_ToggleClipPlane, section views) in scene graphs:
    ``[((3,) normal, distance mm)]``; coin keeps ``normal . p >= distance``."""
    coin = _coin()
    out = []
    for sg in graphs:
        sa = coin.SoSearchAction()
        sa.setType(coin.SoClipPlane.getClassTypeId(), True)
        sa.setInterest(coin.SoSearchAction.ALL)
        sa.apply(sg)
        paths = sa.getPaths()
        for i in range(paths.getLength()):
            node = paths[i].getTail()
            if hasattr(node, "on") and not node.on.getValue():
                continue
            pl = node.plane.getValue()
            n = pl.getNormal()
            out.append(((float(n[0]), float(n[1]), float(n[2])),
                        float(pl.getDistanceFromOrigin())))
    return out


