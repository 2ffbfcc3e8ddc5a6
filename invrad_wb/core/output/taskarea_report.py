"""The explicit task areas in the design report (:mod:`invrad_wb.core.design.taskareas`):
their figures per area (the summary's and the rooms' rows), which area a plan point lies
in (each area's values thinned on their own), their dashed outlines on the room plan and
the plan's words for its iso-lux lines."""
import numpy as np

from invrad_wb.core.output.figures import iso_levels


def task_area_figures(r):
    """The explicit task areas of a designed room with their figures (dicts: name,
    area_m2, lux, u0_req, em, emin, u0, ok, source), [] for a room judged on its work
    plane less a border zone."""
    areas = getattr(r.requirement, "task_areas", ()) if r.metrics is not None else ()
    out = []
    for a in areas:
        k = a.part                  # its surface grid's name
        if k not in r.metrics.surfaces:
            continue
        em, emin, u0 = r.metrics.surfaces[k]
        q = r.surface_reqs[k]
        out.append({"name": a.name, "area_m2": a.area_m2, "lux": q.lux, "u0_req": q.u0,
                    "em": em, "emin": emin, "u0": u0, "ok": bool(r.verdicts.get(k)),
                    "source": q.source.split("; task area")[0]})
    return out


def per_area(areas, fmt):
    """One table cell of the areas' figures: each area's ``fmt(area)``, ``'; '`` between."""
    return "; ".join(fmt(a) for a in areas)


def area_of(pts, rd):
    """(n,) index of the explicit task area each plan point lies in (0: none)."""
    from matplotlib.path import Path
    out = np.zeros(len(pts), dtype=int)
    for i, a in enumerate(rd.requirement.task_areas):
        out[Path(np.asarray(a.polygon, dtype=float)).contains_points(pts[:, :2])] = i + 1
    return out


def iso_words(lux, required):
    """The plan's words for its iso-lux lines: 'iso-lux lines every 20 lx, 500 lx bold'
    (or 'at 400, 500, 650 lx' where the required level breaks the step)."""
    levels = iso_levels(lux, required)
    if not levels:
        return "no iso-lux lines (the light is even)"
    d = np.diff(levels)
    at = (f"every {d[0]:g} lx" if len(d) and np.allclose(d, d[0])
          else "at " + ", ".join(f"{v:g}" for v in levels) + " lx")
    bold = (f", {required:g} lx bold" if required is not None
            and any(abs(v - required) < 1e-6 for v in levels) else "")
    return f"iso-lux lines {at}{bold}"


def draw_task_outlines(axes, rd):
    """The explicit task areas' outlines on the plan's panels, named on the values'
    panel (above the area, where no value is printed)."""
    for a in getattr(rd.requirement, "task_areas", ()):
        p = np.asarray(a.polygon, dtype=float)
        q = np.r_[p, p[:1]]
        axes[0].plot(q[:, 0], q[:, 1], color="0.1", lw=1.0, ls="--", zorder=3)
        axes[1].plot(q[:, 0], q[:, 1], color="0.35", lw=0.8, ls="--", zorder=1)
        axes[1].annotate(a.name, (float(p[:, 0].mean()), float(p[:, 1].max())),
                         xytext=(0, 2), textcoords="offset points", ha="center",
                         va="bottom", fontsize=6.5, color="0.25", style="italic")
