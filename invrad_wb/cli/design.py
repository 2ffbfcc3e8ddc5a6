"""``python -m invrad_wb design SCENE --spec DESIGN.json -o RESULT.json``: lighting design
from requirements on a plain mesh (PLY with ``room`` and ``reflectance``; ``lux`` may be NaN
everywhere, 0 marks points that must stay dark).

Exit status: 0 when every room with a requirement complies, 3 when at least one cannot
(the closest design is written all the same and the reason printed), 2 on bad input.
"""
import csv
import io
import json
import os
import sys

from invrad_wb.cli.common import batch_scenes, run_batch
from invrad_wb.progress import CliProgress, add_parallel_args, floor_note, workers_arg

#: exit status of a design that does not meet every requirement
EXIT_NOT_COMPLIANT = 3


def add_parser(sub):
    p = sub.add_parser("design", help="lighting design from requirements (least watts)")
    p.add_argument("scene", nargs="+",
                   help="scene file (PLY with room and reflectance); several files or folders"
                        " of PLY files: one process for all, -o (and --schedule) are then"
                        " folders, --report gets one subfolder per scene")
    p.add_argument("--spec", required=True, help="DESIGN.json: requirements and catalogue")
    p.add_argument("-o", "--output", required=True, help="RESULT.json (several scenes: a folder)")
    p.add_argument("--schedule", help="also write the luminaire schedule as CSV")
    p.add_argument("--report", help="folder for the client's report (HTML, CSV, plans)")
    p.add_argument("--unit", default="m", choices=("m", "mm"), help="scene length unit")
    p.add_argument("--backend", default="auto", choices=("auto", "opencl", "numpy"))
    p.add_argument("--no-mixed", dest="mixed", action="store_false",
                   help="one catalogue entry per room")
    p.add_argument("--no-dimming", dest="dimming", action="store_false",
                   help="ignore the catalogue's dimming ranges")
    p.add_argument("-v", "--verbose", action="store_true", help="one line per step")
    add_parallel_args(p)
    p.set_defaults(func=run)


def schedule_csv(result):
    """The luminaire schedule of a design as CSV text: one row per room, type and output
    setting (a type dimmed apart has a row per dimming group, its letter as in the report
    in the last column; lm and W each at that output, W total its luminaires' own
    watts)."""
    from invrad_wb.core.output.groups import output_groups
    buf = io.StringIO()
    w = csv.writer(buf)
    w.writerow(["room", "type", "count", "flux_lm", "watts_each", "dim", "watts_total",
                "efficacy_lm_per_w", "group"])
    cat = {e.name: e for e in result.spec.catalogue}
    for r in result.rooms:
        for g in output_groups(r, result.spec.catalogue):
            w.writerow([r.name, g["type"], g["count"], f"{g['flux_lm']:.0f}",
                        f"{g['watts']:.2f}", f"{g['fraction']:.3f}",
                        f"{g['watts_total']:.2f}", f"{cat[g['type']].efficacy:.1f}",
                        g["label"]])
    return buf.getvalue()


def _dimmed_words(r):
    """', dimmed to 32 %', or ', dimmed apart to 10-100 % (32 % of the rated power)'
    where the luminaires run at outputs of their own, or ''."""
    x = 100 * r.general_outputs()
    if not len(x) or x.min() >= 100 - 1e-6:
        return ""
    if round(x.min()) == round(x.max()):
        return f", dimmed to {x.min():.0f} %"
    return (f", dimmed apart to {x.min():.0f}-{x.max():.0f} %"
            f" ({100 * r.candidate.dim:.0f} % of the rated power)")


def _no_background(r):
    """' no background area,' (or why it is not judged) where the room has none."""
    if any(k.startswith("background") for k in r.surface_reqs):
        return ""
    w = r.background_words or ""
    return " no background area," if w.startswith("none") else " background not judged,"


def _print_room(r):
    if r.metrics is None:
        print(f"{r.name}: {'; '.join(r.notes)}")
        return
    m, q = r.metrics, r.requirement
    types = ", ".join(f"{n} x {t}" for t, n in sorted(r.schedule().items()))
    verdict = "meets" if r.compliant else "DOES NOT MEET"
    print(f"{r.name}: {types} ({r.candidate.geom.describe()}"
          + _dimmed_words(r)
          + ("):" if getattr(q, "task_areas", ()) else     # each area's below
             f"): Em {m.em:.0f} lx (>= {q.lux:g}), U0 {m.u0:.2f} (>= {q.u0:g}),")
          + "".join(f" {k} Em {m.surfaces[k][0]:.0f} lx (>= {s.lux:.4g})"
                    f" U0 {m.surfaces[k][2]:.2f} (>= {s.u0:g}),"
                    for k, s in r.surface_reqs.items() if k in m.surfaces)
          + _no_background(r)
          + (f" Ez {r.cyl_figures['em_lux']:.0f} lx (>= {r.cylindrical['lux']:g})"
             f" U0 {r.cyl_figures['u0']:.2f} (>= {r.cylindrical['u0']:g}),"
             if r.cylindrical is not None and r.cyl_figures is not None else "")
          + (f" UGR {r.ugr:.1f}" + (f" (<= {r.ugr_limit:g})" if r.ugr_limit else "") + ","
             if r.ugr is not None else " UGR not computable,")
          + f" {r.watts:.1f} W drawn, {r.rated_watts:.1f} W installed"
          f" ({r.w_per_m2:.2f} W/m^2"
          + (f", {r.w_per_m2_100lx:.2f} W/m^2/100 lx" if r.w_per_m2_100lx else "") + ")"
          + (f", {r.energy_kwh:.0f} kWh/a" if r.energy_kwh is not None else "")
          + f": {verdict} the requirement")
    for note in r.notes:
        print(f"  note: {note}")


def run(args):
    from invrad_wb.core.design.spec import read_spec
    from invrad_wb.outputs import check_file, check_folder
    spec = read_spec(args.spec)
    workers = workers_arg(args.workers)
    scenes = args.scene
    if not (len(scenes) > 1 or os.path.isdir(scenes[0])):
        check_file(args.output, "-o", inputs=[scenes[0], args.spec])
        if args.schedule:
            check_file(args.schedule, "--schedule", inputs=[scenes[0], args.spec])
        if args.report:
            check_folder(args.report, "--report")
        return _design_one(args, scenes[0], args.output, args.schedule, args.report, spec,
                           workers)
    # many scenes in one process: one OpenCL context, kernels built once
    scenes = batch_scenes(scenes)
    check_folder(args.output, "-o (a folder for RESULT.json files with several scenes)")
    for opt, what in ((args.schedule, "--schedule"), (args.report, "--report")):
        if opt:
            check_folder(opt, f"{what} (a folder with several scenes)")

    def one(path, stem):
        out = os.path.join(args.output, stem + ".json")
        sched = args.schedule and os.path.join(args.schedule, stem + ".csv")
        for f, what in ((out, "-o"), (sched, "--schedule")):
            if f:
                os.makedirs(os.path.dirname(f), exist_ok=True)
                check_file(f, what, inputs=[path, args.spec])
        return _design_one(args, path, out, sched, args.report and
                           os.path.join(args.report, stem), spec, workers)
    failed, seconds = run_batch(scenes, one)
    print(f"{len(scenes)} scene(s) designed in {seconds:.1f} s, "
          f"{sum(1 for _, rc in failed if rc == EXIT_NOT_COMPLIANT)} not compliant,"
          f" {sum(1 for _, rc in failed if rc == 2)} failed -> {args.output}")
    if failed:
        return 2 if any(rc == 2 for _, rc in failed) else EXIT_NOT_COMPLIANT
    return 0


def _design_one(args, scene_path, output, schedule, report, spec, workers):
    """One scene: design, write RESULT.json (schedule, report), print the rooms."""
    from invrad_wb.core.design.design import design
    from invrad_wb.core.io.atomic import atomic_write_text
    from invrad_wb.core.io.sceneio import read_scene
    scene = read_scene(scene_path, unit=args.unit)
    # a plain mesh's rooms have ids only: a single room takes the scene's name (as in the
    # verification report), so the report and the schedule do not say 'room 0'
    names = ({int(scene.rooms[0]): os.path.splitext(os.path.basename(scene_path))[0]}
             if len(scene.rooms) == 1 else None)
    note = floor_note(scene, workers, "designed")      # rooms x faces
    if note:
        print(f"invrad: {note}", file=sys.stderr)
    with CliProgress(args.verbose, "design") as progress:
        result = design(scene, spec, room_names=names, backend=args.backend,
                        progress=progress,
                        mixed=args.mixed, dimming=args.dimming, workers=workers,
                        dask=args.dask)
    data = result.to_dict()
    atomic_write_text(output, json.dumps(data, indent=2, allow_nan=False) + "\n")
    if schedule:
        atomic_write_text(schedule, schedule_csv(result))
    if report:
        html = result.write_report(report,
                                   title=f"Lighting design: {os.path.basename(scene_path)}")
        print(f"report -> {html}")
    for r in result.rooms:
        _print_room(r)
    print(f"{len(result.luminaires)} luminaire(s), {result.watts:.1f} W drawn,"
          f" {result.rated_watts:.1f} W installed in"
          f" {result.timings['total']:.1f} s -> {output}")
    if not result.compliant:
        print(f"invrad: {scene_path}: the catalogue cannot meet every requirement: the"
              " closest design is written (see the notes above)", file=sys.stderr)
        return EXIT_NOT_COMPLIANT
    return 0
