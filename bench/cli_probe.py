#!/usr/bin/env python3
"""Run ``python -m invrad_wb ARGS`` in this process with every stage timed, in wall and
CPU seconds (this process, all threads: PoCL's included); used by ``bench_cli.py``.

Usage: INVRAD_PROBE_ROOT=CHECKOUT INVRAD_PROBE_OUT=STAGES.json python cli_probe.py ARGS

``CHECKOUT`` is the invrad checkout whose CLI runs (default: the one holding this file), so
that one probe times any revision the same way: it only wraps functions from outside, the
CLI's code is unchanged. Stages are exclusive (a stage nested in another is charged to the
inner one only), so they add up to the time inside the process:

* ``imports``: loading modules, wherever it happens (``importlib``'s ``_find_and_load``);
* ``opencl context``: the first :func:`get_env` (platform, device, context, queue);
* ``kernel builds``: ``CLEnv.program`` (PoCL's kernel cache makes them cheap after the
  first run);
* ``read scene``, ``requirements check`` (``classify_rooms``), ``locate`` (the core, what
  is left of it), ``write``: RESULT.json and vote maps (``atomic_write_text``,
  ``strict_json``, ``save_vote_maps``), ``cli other``: the rest (argument parsing, printing).

The core's own stage seconds (``result.timings``: sampling, maps, votes, postprocess,
radiosity) are recorded too, in wall and CPU seconds: they include whatever import or kernel
build happened inside them. So are parts of the refinement, inclusive and overlapping
(``detail``: the optimiser's runs, the interreflection solves of the luminaires, the final
refit on every target vertex, which runs the other two as well). The interpreter's start (before this file runs) is measured by
the caller: the child's seconds minus the ones recorded here ("start + exit": also the
interpreter's finalisation after the exit hooks).
"""
import json
import os
import sys
import time

_T0_WALL, _T0_CPU = time.perf_counter(), time.process_time()
ROOT = os.environ.get("INVRAD_PROBE_ROOT") or os.path.dirname(
    os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, ROOT)

_stages = {}
_stack = ["cli other"]
_mark = [_T0_WALL, _T0_CPU]


def _charge():
    w, c = time.perf_counter(), time.process_time()
    acc = _stages.setdefault(_stack[-1], [0.0, 0.0])
    acc[0] += w - _mark[0]
    acc[1] += c - _mark[1]
    _mark[0], _mark[1] = w, c


def _push(name):
    _charge()
    _stack.append(name)


def _pop():
    _charge()
    _stack.pop()


def _timed(name, fn, once=False):
    state = {"done": False}

    def wrapper(*a, **kw):
        if once and state["done"]:
            return fn(*a, **kw)
        _push(name)
        try:
            return fn(*a, **kw)
        finally:
            state["done"] = True
            _pop()
    wrapper.__wrapped__ = fn
    return wrapper


class _Stamp(float):
    """A wall-clock reading that also carries the CPU clock's: what the core's stage
    timers (``t = time.time(); ...; timings[k] += time.time() - t``) add up."""

    def __new__(cls, wall, cpu):
        v = float.__new__(cls, wall)
        v.cpu = cpu
        return v

    def __sub__(self, other):
        if isinstance(other, _Stamp):
            return _Stamp(float(self) - float(other), self.cpu - other.cpu)
        return float(self) - other

    def __add__(self, other):
        return _Stamp(float(self) + float(other), self.cpu + getattr(other, "cpu", 0.0))

    __radd__ = __add__

    def __round__(self, n=None):
        return _Stamp(round(float(self), n or 0), self.cpu)


class _DualClock:
    def __getattr__(self, name):
        return getattr(time, name)

    @staticmethod
    def time():
        return _Stamp(time.time(), time.process_time())


_core = {}
#: inclusive seconds (wall, CPU) of parts of the refinement (they overlap: the final refit
#: runs the optimiser and solves interreflection too)
_detail = {}
DETAIL = (("invrad_wb.core.inverse.refine", "RefineProblem", "levenberg_marquardt",
           "optimiser (LM)"),
          ("invrad_wb.core.inverse.locate_problem", "_Indirect", "__call__",
           "indirect solves"),
          ("invrad_wb.core.inverse.locate_fit", "_RoomFit", "polish", "final refit"))


def _inclusive(name, fn):
    depth = [0]

    def wrapper(*a, **kw):
        if depth[0]:
            return fn(*a, **kw)
        depth[0] += 1
        w, c = time.perf_counter(), time.process_time()
        try:
            return fn(*a, **kw)
        finally:
            depth[0] -= 1
            acc = _detail.setdefault(name, [0.0, 0.0, 0])
            acc[0] += time.perf_counter() - w
            acc[1] += time.process_time() - c
            acc[2] += 1
    wrapper.__wrapped__ = fn
    return wrapper


def _patch(module):
    """Wrap the functions of a module just loaded (before anyone binds them)."""
    name = module.__name__
    for mod, cls, meth, label in DETAIL:
        if name == mod and hasattr(module, cls):
            klass = getattr(module, cls)
            setattr(klass, meth, _inclusive(label, getattr(klass, meth)))
    if name == "invrad_wb.core.accel.device":
        module.get_env = _timed("opencl context", module.get_env, once=True)
        module.CLEnv.program = _timed("kernel builds", module.CLEnv.program)
    elif name == "invrad_wb.core.io.sceneio":
        module.read_scene = _timed("read scene", module.read_scene)
    elif name == "invrad_wb.core.io.atomic":
        module.atomic_write_text = _timed("write", module.atomic_write_text)
    elif name == "invrad_wb.cli.common":
        module.strict_json = _timed("write", module.strict_json)
    elif name == "invrad_wb.core.design.requirements":
        module.classify_rooms = _timed("requirements check", module.classify_rooms)
    elif name == "invrad_wb.core.inverse.locate_result":
        module.LocateResult.save_vote_maps = _timed("write", module.LocateResult.save_vote_maps)
        module.time = _DualClock()
    elif name in ("invrad_wb.core.inverse.locate_problem",):
        module.time = _DualClock()
    elif name == "invrad_wb.core.inverse.locate":
        module.time = _DualClock()
        inner = module.locate

        def locate(*a, **kw):
            r = inner(*a, **kw)
            for k, v in r.timings.items():
                _core[k] = [float(v), getattr(v, "cpu", 0.0 if v == 0 else float("nan"))]
                r.timings[k] = float(v)
            return r
        module.locate = _timed("locate", locate)


def _install_import_timer():
    import importlib._bootstrap as B
    inner = B._find_and_load

    def _find_and_load(name, import_):
        _push("imports")
        try:
            m = inner(name, import_)
        finally:
            _pop()
        if name.startswith("invrad_wb") and not getattr(m, "_probe_patched", False):
            m._probe_patched = True
            _patch(m)
        return m
    B._find_and_load = _find_and_load


def _write():
    _charge()
    out = os.environ.get("INVRAD_PROBE_OUT")
    if out:
        with open(out, "w", encoding="utf-8") as fh:
            json.dump({"stages": _stages, "core": _core, "detail": _detail,
                       "inside": [time.perf_counter() - _T0_WALL,
                                  time.process_time() - _T0_CPU]}, fh)


def main():
    """``python -m invrad_wb ARGS`` of the checkout, its own ``__main__`` (how it ends the
    process included); the stages are written by an exit hook (the first registered, so
    the last to run: after the command's own hooks)."""
    import atexit
    import runpy
    atexit.register(_write)
    _install_import_timer()
    sys.argv = ["invrad_wb"] + sys.argv[1:]
    runpy.run_module("invrad_wb", run_name="__main__", alter_sys=True)


if __name__ == "__main__":
    main()
