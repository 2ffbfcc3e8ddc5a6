"""The workbench's headless start-up (Init.py) and its IFC import hook."""
import os

import FreeCAD

from fctest import FZK, ROOT, FreeCADTestCase, needs_fzk
from invrad_wb.app import fixtures, ifcexport, rooms
from invrad_wb.core.model.luminaires import Luminaire


class TestInit(FreeCADTestCase):

    def test_init_is_tiny_and_registers_the_ifc_importer(self):
        import sys
        before = set(sys.modules)
        path = os.path.join(ROOT, "Init.py")
        with open(path, encoding="utf-8") as fh:
            exec(compile(fh.read(), path, "exec"), {"__name__": "Init"})
        loaded = {m for m in set(sys.modules) - before if m.startswith("invrad_wb")}
        self.assertEqual(loaded, set(), "Init.py must not import the package")
        self.assertIn("invrad_wb.app.ifcimport", FreeCAD.getImportType("ifc"))

    def test_layers(self):
        """core never imports FreeCAD; app never imports FreeCADGui (STYLE.md layers)."""
        import re
        pkg = os.path.join(ROOT, "invrad_wb")
        for sub, banned in (("core", r"^\s*(import|from)\s+(FreeCAD|FreeCADGui|Part|Arch)\b"),
                            ("app", r"^\s*(import|from)\s+FreeCADGui\b")):
            folder = os.path.join(pkg, sub)
            for name in sorted(os.listdir(folder)):
                if name.endswith(".py"):
                    with open(os.path.join(folder, name), encoding="utf-8") as fh:
                        for i, line in enumerate(fh, 1):
                            self.assertIsNone(re.search(banned, line),
                                              f"{sub}/{name}:{i}: {line.strip()}")


@needs_fzk
class TestImportHook(FreeCADTestCase):

    def test_open_brings_rooms_and_building_elements(self):
        from invrad_wb.app import ifcimport
        doc = ifcimport.open(FZK)
        self.assertEqual(len(rooms.find_spaces(doc)), 7)
        types = {}
        for o in doc.Objects:
            if getattr(o, "IfcType", None) and o.TypeId == "Part::FeaturePython" \
                    and not rooms.is_space(o):
                types[o.IfcType] = types.get(o.IfcType, 0) + 1
        self.assertGreaterEqual(types.get("Wall", 0), 13)
        self.assertEqual(types.get("Window", 0), 11)
        self.assertEqual(types.get("Door", 0), 5)
        # such a document also goes through FreeCAD's own exporter
        space = rooms.get_space(doc, "Bad")
        fixtures.insert_fixtures(doc, [(space, [Luminaire([9.0, 6.0, 2.5], [0, 0, -1],
                                                          800.0)])])
        out = self.path("fzk_fc.ifc")
        info = ifcexport.export_ifc(doc, out, base_ifc=False)
        import ifcopenshell
        import ifcopenshell.util.element as E
        ifc = ifcopenshell.open(out)
        (lf,) = ifc.by_type("IfcLightFixture")
        self.assertEqual(E.get_container(lf).Name, "Bad")
        self.assertGreaterEqual(len(ifc.by_type("IfcWall")), 13)
        self.assertEqual(info.warnings, [])
