"""Found luminaires -> real BIM light fixtures in the document (and back).

Each luminaire becomes an Arch Equipment with ``IfcType = "Light Fixture"``:

* **Placement**: its origin is the luminaire's position (the point found by locate on
  the mounting surface); its **local -Z axis is the light direction**, i.e. the found
  normal pointing into the room (a ceiling luminaire has the identity rotation; a wall
  washer's -Z is horizontal). ``LightDirection`` repeats it as a global unit vector.
* **Body** (:func:`fixture_size`, :func:`fixture_shape`): sized from the luminaire's
  luminous area: a downlight disc of its emitter radius, or of its photometry file's
  luminous opening (a panel when that opening is 0.09 m2 or more: the file's length and
  width along the luminaire's C0 and C90 axes, a square of its area when it gives none);
  a point emitter
  without photometry gets a ``settings.FIXTURE_RADIUS_M`` disc. It is
  ``settings.FIXTURE_THICKNESS_M`` thick, from local z = -thickness to 0, i.e. just below
  the mounting surface, in the room. A **pendant** (facing down, more than
  ``settings.PENDANT_MIN_DROP_M`` below the ceiling above it, or ``extra['mount'] ==
  'pendant'``) hangs from the ceiling on a rod with a canopy (:func:`ceiling_drop_m`). The
  shape is the Equipment's own (no base object), so a document stays light with hundreds
  of fixtures; it is one solid (the IFC exporter writes it as the fixture's body).
* **View** (:func:`style_fixture`, in the GUI): a warm light colour that glows (emissive),
  so fixtures stand out from the building and the false colours; selectable as usual.
* **Label**: ``Luminaire <room> <n>``, with the catalogue type a design chose in
  parentheses (the fixtures are listed under their Space in the tree).
* **Photometry**: ``LuminousFlux`` (lm), ``EmitterRadius`` (0 = point emitter) and the
  locate ``Score`` as properties, mirrored in ``IfcProperties`` so that FreeCAD's IFC
  exporter writes them as the custom property set ``InvRad_Luminaire`` (IFC has no
  standard fixture flux; Pset_LightFixtureTypeCommon gets NumberOfSources = 1).
* **Room**: fixtures are put inside their Space (``Space.Group``: Arch's "objects that
  are included inside this space, such as furniture"), and ``Room`` links back to it. The
  link is an ``App::PropertyLinkHidden``: a plain link would close a dependency cycle with
  the Space's Group ("The graph must be a DAG").

:func:`insert_fixtures` makes all of it ONE undoable transaction and, by default, first
removes the fixtures a previous invrad run put into the same rooms (``Generator`` tag).

In a NativeIFC document the same luminaires become IfcLightFixture entities
(:mod:`.nativeifc`). Which of the two, the document's backend decides (:mod:`.backend`,
once per document); the Arch Equipment themselves are made in :mod:`.classic`.
"""
from invrad_wb.app import backend
# the classic backend's fixtures and the body and frame (both backends and the IFC export
# use them): fixtures.make_fixture, fixtures.fixture_size etc. as before
from invrad_wb.app.classic import (  # noqa: F401
    FIXTURE_EMISSIVE_RGB, FIXTURE_LINE_RGB, FIXTURE_RGB, LIGHT_FIXTURE, ceiling_drop_m,
    make_fixture, style_fixture)
from invrad_wb.app.fixturebody import (  # noqa: F401
    CANOPY_RADIUS_M, CANOPY_THICKNESS_M, MIN_RADIUS_M, PANEL_MIN_AREA_M2, ROD_RADIUS_M,
    check_luminaire, fixture_axes, fixture_rotation, fixture_shape, fixture_size, new_guid)


def fixture_label(space, i, lum):
    """``Luminaire <room> <i + 1>``, with the catalogue type in parentheses if known (the
    room by :func:`~invrad_wb.app.rooms.room_name`: a NativeIFC space's LongName)."""
    kind = lum.extra.get("type")
    return f"Luminaire {backend.of(space).room_name(space)} {i + 1}" + (
        f" ({kind})" if kind else "")


def is_fixture(obj, generated_only=False):
    return backend.of(obj).is_fixture(obj, generated_only)


def room_fixtures(space, generated_only=True):
    """Light fixtures inside a Space (those made by invrad only, by default)."""
    return backend.of(space).room_fixtures(space, generated_only)


def all_fixtures(doc, generated_only=True):
    be = backend.of(doc)
    return [o for o in doc.Objects if be.is_fixture(o, generated_only)]


def fixture_room(obj):
    """The Space of a fixture: its Room link, else the Space whose Group holds it."""
    return backend.of(obj).fixture_room(obj)


def insert_fixtures(doc, per_room, replace=True, name="Insert luminaires", requirements=None):
    """Insert luminaires as light fixtures, room by room, as ONE undoable transaction.

    Parameters
    ----------
    doc : FreeCAD document
    per_room : list of (Space, list of Luminaire)
    replace : bool
        First remove the fixtures that invrad put into these rooms before.
    requirements : dict, optional
        ``{Space Name: (required lux, achieved dict or None)}`` written to the rooms' IFC
        data in the same step (:meth:`.backend.DocumentBackend.write_requirements`).

    Returns
    -------
    list of the new fixture objects, in the order given.

    Raises
    ------
    LuminaireError, SceneError
        Bad luminaire or room; the document is left unchanged.
    """
    from invrad_wb.app import aimsync
    aimsync.install()              # a moved aimed fixture's aim follows it
    return backend.of(doc).insert_fixtures(doc, per_room, fixture_label, replace=replace,
                                           name=name, requirements=requirements)


def fixture_luminaire(obj):
    """The Luminaire a fixture stands for (position, direction, flux, radius, score)."""
    return backend.of(obj).fixture_luminaire(obj)
