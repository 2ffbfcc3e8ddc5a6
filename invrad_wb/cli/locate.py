"""``invrad locate SCENE [--flux LM] -o RESULT.json [--vote-maps DIR]``: find luminaire
positions (and, without ``--flux``, each one's flux); several scenes in one process."""
from dataclasses import asdict, fields
import json
import os
import sys

import numpy as np

from invrad_wb.cli.common import (batch_scenes, bool_arg, photometry_arg, run_batch,
                                  scene_args, strict_json, warn_suspicious_targets,
                                  with_photometry)
from invrad_wb.core.model.targets import no_luminaire_reason, require_targets
from invrad_wb.errors import InvradError, SettingsError
from invrad_wb.outputs import check_file, check_folder
from invrad_wb.progress import CliProgress, add_parallel_args, floor_note, workers_arg


def add_parser(sub):
    p = sub.add_parser("locate", help="find luminaire positions for the scene's targets")
    scene_args(p, many=True)
    p.add_argument("--flux", type=float,
            help="flux of one luminaire, lm (default: the --photometry file's; without"
                 " either, each luminaire's flux is fitted)")
    p.add_argument("-o", "--output", required=True,
            help="RESULT.json (with several scenes: a folder)")
    p.add_argument("--vote-maps", help="folder for vote-map images (several scenes: one"
                                       " subfolder each)")
    p.add_argument("--settings", help="JSON file with locate settings")
    p.add_argument("-v", "--verbose", action="store_true", help="one line per step")
    add_parallel_args(p)
    g = p.add_argument_group("locate settings (defaults need only the flux)")
    options = {}                         # setting -> the option that gives it

    def setting(name, **kw):
        options[g.add_argument(name, **kw).dest] = name

    setting("--vote-model", dest="vote_model", choices=("exact", "ellipse"))
    setting("--resolution", dest="pixel_m", type=float, metavar="M",
            help="vote-map resolution, metres per pixel (0.1); not the room mesh"
                 " size, which is `freecad --mesh-size`")
    setting("--votes-per-m2", dest="votes_per_m2", type=float)
    setting("--weighting", choices=("illumination", "distance", "both", "none"))
    setting("--vote-strength", dest="vote_strength", type=float)
    setting("--occlusion", type=bool_arg, help="auto/true/false")
    setting("--dummy-planes", dest="dummy_planes", type=bool_arg)
    setting("--dummy-spacing", dest="dummy_spacing_m", type=float)
    setting("--dummy-count", dest="dummy_count", type=int)
    setting("--two-sided-dummies", dest="two_sided_dummies", type=bool_arg)
    setting("--all-planes", dest="all_planes", type=bool_arg)
    setting("--threshold", type=float, help="0-254 (24)")
    setting("--neighbourhood", dest="neighbourhood_m", type=float, help="metres (0.3)")
    setting("--refine", type=bool_arg, help="joint refinement (true)")
    setting("--optimiser", choices=("lm", "es"))
    setting("--indirect", choices=("radiosity", "ambient", "none"))
    setting("--aim", choices=("fixed", "free"),
            help="fixed: luminaires face along their surface's normal (default);"
                 " free: fit each mounted luminaire's aim too (adjustable spots)")
    setting("--max-tilt", dest="max_tilt_deg", type=float, metavar="DEG",
            help="with --aim free: largest tilt from the surface's normal (70)")
    p.set_defaults(func=run, setting_options=options)


def _settings_from_args(args):
    from invrad_wb.core.inverse.locate import LocateSettings
    s = LocateSettings()
    given = {}
    for f in fields(LocateSettings):
        v = getattr(args, f.name, None)
        if v is not None:
            setattr(s, f.name, v)
            given[f.name] = getattr(args, "setting_options", {}).get(f.name, f.name)
    try:
        s.check()
    except SettingsError as exc:         # name the option the user typed, not the field
        name = str(exc).split(" ", 1)[0]
        if name in given:
            raise SettingsError(given[name] + str(exc)[len(name):])
        raise
    if getattr(args, "settings", None):
        try:
            with open(args.settings, "r", encoding="utf-8") as fh:
                d = json.load(fh)
        except (OSError, json.JSONDecodeError, UnicodeDecodeError) as exc:
            raise InvradError(f"{args.settings}: cannot read settings: {exc}")
        if not isinstance(d, dict):
            raise InvradError(f"{args.settings}: settings must be a JSON object of"
                              f" name: value, got {type(d).__name__}")
        try:
            s = LocateSettings.from_dict({**asdict(s), **d})
        except InvradError as exc:
            raise InvradError(f"{args.settings}: {exc}")
    return s.check()


def run(args):
    scenes = args.scene
    batch = len(scenes) > 1 or os.path.isdir(scenes[0])
    settings = _settings_from_args(args)
    if args.flux is not None:
        from invrad_wb.core.inverse.locate import check_flux
        try:
            check_flux(args.flux)
        except SettingsError as exc:
            raise SettingsError(f"--{exc}")
    phot = photometry_arg(args)
    workers = workers_arg(args.workers)
    if args.flux is None and phot is not None and phot.flux_lm:
        args.flux = phot.flux_lm
        print(f"flux of one luminaire: {args.flux:.0f} lm, from {args.photometry}")
    elif args.flux is None:
        print("no --flux: the number, positions and flux of each luminaire are fitted")
    if not batch:
        check_file(args.output, "-o", inputs=scenes)
        if args.vote_maps:
            check_folder(args.vote_maps, "--vote-maps")
        return _locate_one(args, scenes[0], args.output, args.vote_maps, settings, phot,
                           workers)
    # many scenes in one process: one OpenCL context, kernels built once
    if args.lux or args.texture:
        raise InvradError("--lux/--texture name one scene's sidecar: with several scenes"
                          " give PLY files that carry their targets")
    scenes = batch_scenes(scenes)
    check_folder(args.output, "-o (a folder for RESULT.json files with several scenes)")
    if args.vote_maps:
        check_folder(args.vote_maps, "--vote-maps")
    os.makedirs(args.output, exist_ok=True)

    def one(path, stem):
        out = os.path.join(args.output, stem + ".json")
        check_file(out, "-o", inputs=[path])
        return _locate_one(args, path, out, args.vote_maps and
                           os.path.join(args.vote_maps, stem), settings, phot, workers)
    failed, seconds = run_batch(scenes, one)
    print(f"{len(scenes) - len(failed)} of {len(scenes)} scene(s) located in"
          f" {seconds:.1f} s -> {args.output}")
    if failed:
        print("invrad: no result for: " + ", ".join(p for p, _ in failed), file=sys.stderr)
        return max(rc for _, rc in failed)


def _locate_one(args, scene_path, output, vote_maps, settings, phot, workers):
    """One scene: locate, write RESULT.json (and vote maps), print the luminaires."""
    from invrad_wb.core.io.atomic import atomic_write_text
    from invrad_wb.core.inverse.locate import locate
    from invrad_wb.core.io.sceneio import read_scene
    scene = read_scene(scene_path, lux=args.lux, texture=args.texture,
                       texture_max_lux=args.texture_max_lux, unit=args.unit)
    require_targets(scene, scene_path, args.lux, args.texture)
    warn_suspicious_targets(scene_path, scene)
    note = floor_note(scene, workers, "located")      # rooms x faces
    if note:
        print(f"invrad: {note}", file=sys.stderr)
    with CliProgress(args.verbose, "locate") as progress:
        # a plain mesh's single room takes the scene's name (progress, vote-map titles)
        names = ({int(scene.rooms[0]): os.path.splitext(os.path.basename(scene_path))[0]}
                 if len(scene.rooms) == 1 else None)
        kinds = {}
        if args.flux is not None:        # a level on a work plane is a requirement
            from invrad_wb.core.design.requirements import classify_rooms
            kinds = classify_rooms(scene, [int(r) for r in scene.rooms], names)
        verdicts = None
        if any(k.requirement for k in kinds.values()):
            result, verdicts = _locate_requirements(scene, kinds, args, settings, phot,
                                                    workers, names, progress)
        else:
            result = locate(scene, args.flux, settings=settings, backend=args.backend,
                            progress=progress, photometry=phot, workers=workers,
                            dask=args.dask, room_names=names)
    with_photometry(result.luminaires, phot)
    data = result.to_dict()
    if verdicts is not None:
        data["verdicts"] = verdicts
    if vote_maps:                  # first: an interrupted map write leaves RESULT.json as it was
        files = result.save_vote_maps(vote_maps)
    atomic_write_text(output, strict_json(data))
    for l in result.luminaires:
        p = ", ".join(f"{x:.3f}" for x in l.position)
        n = ", ".join(f"{round(float(x), 2) + 0.0:.2f}" for x in l.normal)   # never -0.00
        score = "" if l.score is None else f", score {l.score:.3f}"   # None: a layout's
        print(f"room {l.room}: luminaire at ({p}) m facing ({n}), {l.flux_lm:.0f} lm"
              f"{score} [{l.extra.get('mount', '')}]")
    _say_fit(result, names)
    for v in verdicts or ():
        _say_verdict(v)
    of = "" if args.flux is None else f" of {args.flux:g} lm"
    print(f"{len(result.luminaires)} luminaire(s){of} in"
          f" {result.timings['total']:.2f} s ({result.backend}) -> {output}")
    if vote_maps:
        print(f"vote maps: {len(files)} files in {vote_maps}")
    if not result.luminaires:
        reason = no_luminaire_reason(scene)
        if reason is None:
            lit = np.nan_to_num(scene.vertex_targets(), nan=0.0) > 0
            print(f"invrad: no luminaire{of} explains the targets of"
                  f" {scene_path} ({int(lit.sum())} lit target points): check the flux, the"
                  " units (--unit) and that the targets are reachable from the room's"
                  " surfaces", file=sys.stderr)
            return 3
        print(f"invrad: no luminaire needed: {scene_path}: {reason}", file=sys.stderr)
    return 0


def _locate_requirements(scene, kinds, args, settings, phot, workers, names, progress):
    """Rooms whose targets are requirements (a level on the work plane: :mod:`invrad_wb.
    core.design.requirements`) get a regular layout of the luminaire, as through the
    ``freecad`` command; the other rooms are fitted point by point. Each requirement room
    is then judged as EN 12464-1 does, on the light of every luminaire with
    interreflection. Returns (LocateResult holding every luminaire, verdicts: one dict per
    requirement room)."""
    from dataclasses import asdict
    import time
    from invrad_wb.core.design.requirements import design_requirements, verdict_summary
    from invrad_wb.core.forward.render import render
    from invrad_wb.core.inverse.locate import LocateResult, locate
    names = names or {}
    t0 = time.perf_counter()
    req = design_requirements(scene, kinds, args.flux, photometry=phot, backend=args.backend,
                              room_names=names, progress=progress, workers=workers)
    exact = [r for r, k in kinds.items() if not k.requirement]
    if exact:
        result = locate(scene, args.flux, settings=settings, backend=args.backend,
                        progress=progress, photometry=phot, workers=workers, dask=args.dask,
                        rooms=exact, room_names=names)
    else:
        result = LocateResult([], asdict(settings), {}, args.flux, [], args.backend)
    result.luminaires = list(result.luminaires) + list(req.luminaires)
    with_photometry(result.luminaires, phot)
    achieved = render(scene, result.luminaires, interreflection=True, backend=args.backend)
    verdicts = []
    for r, rt in kinds.items():
        if not rt.requirement:
            continue
        name = names.get(r) or f"room {r}"
        verdicts.append({"room": int(r), **verdict_summary(
            scene, r, rt, achieved, name, req,
            "these targets are requirements: `python -m invrad_wb design` (a catalogue of"
            " luminaires, dimming) finds the layout of least power that meets them")})
    result.timings["requirements"] = round(req.seconds, 4)
    result.timings["total"] = time.perf_counter() - t0
    return result, verdicts


def _say_verdict(v):
    """A requirement room's verdict, as the ``freecad`` command says it."""
    print(f"{'met' if v['met'] else 'NOT met'}: {v['words']}")
    if v.get("layout"):
        print(f"  {v['layout']} ({v.get('mounting', 'ceiling')})")
    for line in v.get("notes", []) + v.get("why_not", []):
        print(f"  {line}")
    if v.get("advice"):
        print(f"  {v['advice']}")


def _say_fit(result, names=None):
    """One line per room: how well the luminaires reproduce its targets; a warning when
    the fit is poor (:mod:`invrad_wb.core.output.fitquality`)."""
    from invrad_wb.core.output.fitquality import poor_fit_warning
    for run in result.rooms:
        fq = getattr(run, "fit", None)
        if fq is None or not fq.targets:
            continue
        name = (names or {}).get(int(run.room)) or f"room {int(run.room)}"
        print(f"{name}: {fq.words()}")
        kinds = {}
        for lum in result.luminaires:
            if lum.room == run.room and "flux_group" in lum.extra:
                kinds.setdefault(lum.extra["flux_group"], []).append(lum.flux_lm)
        for _group, fluxes in sorted(kinds.items()):
            print(f"{name}: {len(fluxes)} luminaires of one kind, {fluxes[0]:.0f} lm each"
                  " (the targets do not tell their fluxes apart: fitted as one)")
        warn = poor_fit_warning(name, fq)
        if warn:
            print(f"invrad: {warn}", file=sys.stderr)
        if getattr(run, "stopped_after_s", None) is not None:
            print(f"invrad: {name}: stopped searching after {run.stopped_after_s:.0f} CPU s of"
                  " refinement: these luminaires cannot explain the targets well (see the"
                  " fit above); the best arrangement found so far is kept", file=sys.stderr)
