"""Every kernel builds and launches on the OpenCL driver at hand, and no kernel calls an
OpenCL built-in on a 512-bit vector (float16, int16, ...).

PoCL 3.0 from PyPI (pyopencl[pocl]) on an AMD Zen 4 builds kernels without AVX-512 but
links AVX-512 built-ins: one such call (``any(int16)``, ``log(float16)``, ``vstore16``)
aborts the whole process when the kernel is first launched (kernels/vec16.h). Debian's PoCL
runs those calls, so the source check below is what keeps them out on any machine; the
launch test runs each kernel variant on whatever driver is present, in a child process (an
abort is a failed test with the driver's words, not a dead test run).
"""
import os
import re
import subprocess
import sys

import pytest

from invrad_wb import constants as C
from invrad_wb.core.accel import probe
from repo_paths import ROOT

#: vector types of 512 bits or more
WIDE = r"(?:float16|u?int16|u?long(?:8|16)|double(?:8|16))"
_KEYWORDS = {"if", "for", "while", "switch", "return", "sizeof", "defined"}
#: a lane selection of at most 8 lanes (.lo, .hi, .even, .odd, .x, .s3, ...)
_PART = re.compile(r"\s*\.\s*(?:lo|hi|even|odd|[xyzw]{1,4}|s[0-9a-fA-F]{1,8})\b")


def _source(path):
    """A kernel file's text without comments, and without vec16.h's whole-vector branch
    (built only for drivers that run it: ``-D INVRAD_SPLIT16`` unset)."""
    with open(path, encoding="utf-8") as fh:
        text = fh.read()
    text = re.sub(r"#else /\* whole: not INVRAD_SPLIT16 \*/.*?#endif /\* INVRAD_SPLIT16 \*/", " ",
                  text, flags=re.S)
    text = re.sub(r"/\*.*?\*/", " ", text, flags=re.S)
    return re.sub(r"//[^\n]*", " ", text)


def _closing(text, i):
    """Index of the parenthesis that closes the one at ``text[i]``."""
    depth = 0
    for j in range(i, len(text)):
        depth += {"(": 1, ")": -1}.get(text[j], 0)
        if depth == 0:
            return j
    return len(text)


def _split_top(text, sep=","):
    parts, depth, start = [], 0, 0
    for j, ch in enumerate(text):
        depth += {"(": 1, ")": -1, "[": 1, "]": -1, "{": 1, "}": -1}.get(ch, 0)
        if ch == sep and depth == 0:
            parts.append(text[start:j])
            start = j + 1
    return parts + [text[start:]]


def _functions(text):
    """(name, return type, whole text) of each top-level function definition."""
    out, depth, start = [], 0, 0
    for j, ch in enumerate(text):
        if ch == "{":
            if depth == 0:
                head = text[start:j]
            depth += 1
        elif ch == "}":
            depth -= 1
            if depth == 0:
                m = re.search(r"(\w+)\s+(\w+)\s*\([^{]*$", head, re.S)
                if m:
                    out.append((m.group(2), m.group(1), text[start:j + 1]))
                start = j + 1
        elif ch == ";" and depth == 0:
            start = j + 1
    return out


def _wide_names(fn_text):
    """Names declared in a function (parameters included) with a 512-bit vector type; a
    pointer counts where it is indexed."""
    names, pointers = set(), set()
    for m in re.finditer(r"\b" + WIDE + r"\b(?!\s*\))", fn_text):   # not a cast
        rest = fn_text[m.end():]
        stop = min([k for k in (rest.find(";"), rest.find("{")) if k >= 0] or [len(rest)])
        decl = rest[:stop]
        p = re.match(r"\s*\*\s*(\w+)", decl)
        if p:
            pointers.add(p.group(1))
        elif not re.match(r"\s*\w+\s*\(", decl):        # not a function's return type
            # a declaration list (a = ..., b, c = ...) or parameters: the first word of
            # each piece (another parameter's first word is a type or qualifier)
            names.update(n.group(1) for n in (re.match(r"\s*(\w+)", piece)
                                              for piece in _split_top(decl)) if n)
    return names, pointers


def wide_builtin_calls(path, user_functions, macros=()):
    """(function, call) of each call of an OpenCL built-in (any function not defined in
    kernels/, not a macro of theirs) whose arguments hold a 512-bit vector, and each call of
    ``vload16``/``vstore16``/``convert_*16``. A reader's check, not a compiler: names are
    those declared with a wide type in the same function."""
    text = _source(path)
    macros = set(macros) | set(re.findall(r"#\s*define\s+(\w+)\(", text))
    text = re.sub(r"#[^\n]*(?:\\\n[^\n]*)*", " ", text)       # directives and macro bodies
    wide_fns = {n for n, (ret, _) in user_functions.items() if re.fullmatch(WIDE, ret)}
    bad = []
    for fname, _, body in _functions(text):
        names, pointers = _wide_names(body)
        for m in re.finditer(r"\b(\w+)\s*\(", body):
            callee = m.group(1)
            if (callee in _KEYWORDS or callee in macros or callee in user_functions
                    or callee == fname or re.fullmatch(r"(?:u?char|u?short|u?int|u?long|float|"
                                                       r"double|half)\d*", callee)):
                continue
            lo = body.index("(", m.start())
            args = body[lo + 1:_closing(body, lo)]
            call = f"{callee}({' '.join(args.split())})"
            if re.fullmatch(r"vload16|vstore16|convert_\w+16(?:_\w+)?", callee):
                bad.append((fname, call))
                continue
            hit = re.search(r"\(\s*(?:const\s+)?" + WIDE + r"\s*\)", args)
            for w in re.finditer(r"\b(\w+)\b", args):
                n, after = w.group(1), args[w.end():]
                if args[:w.start()].rstrip().endswith("."):
                    continue                                   # a member, not a name
                if ((n in names and not _PART.match(after))
                        or (n in pointers and after.lstrip().startswith("[")
                            and not _PART.match(after[after.index("]") + 1:]))
                        or (n in wide_fns and after.lstrip().startswith("("))):
                    hit = True
            if hit:
                bad.append((fname, call))
    return bad


def _kernel_files(folder=C.KERNELS_DIR):
    return sorted(os.path.join(folder, f) for f in os.listdir(folder)
                  if f.endswith((".cl", ".h")))


def _user_functions(folder=C.KERNELS_DIR):
    """({name: (return type, file)} of kernels/' functions, the names of their macros)."""
    fns, macros = {}, set()
    for path in _kernel_files(folder):
        text = _source(path)
        macros.update(re.findall(r"#\s*define\s+(\w+)\(", text))
        for name, ret, _ in _functions(re.sub(r"#[^\n]*(?:\\\n[^\n]*)*", " ", text)):
            fns[name] = (ret, path)
    return fns, macros


def test_no_kernel_calls_a_builtin_on_a_512_bit_vector():
    fns, macros = _user_functions()
    assert {"tent_votes", "leaf_hit", "select16", "log16"} <= set(fns) and "VSTORE16" in macros
    with open(os.path.join(C.KERNELS_DIR, "vec16.h"), encoding="utf-8") as fh:
        assert "vstore16" in fh.read() and "vstore16" not in _source(fh.name)
    bad = [(os.path.basename(p), f, c) for p in _kernel_files()
           for f, c in wide_builtin_calls(p, fns, macros)]
    assert not bad, ("OpenCL built-ins called on 512-bit vectors (PoCL from PyPI aborts on"
                     " them on AVX-512 CPUs; use kernels/vec16.h):\n"
                     + "\n".join(f"  {p} {f}: {c}" for p, f, c in bad))


def test_the_check_sees_wide_calls(tmp_path):
    # what made PoCL from PyPI abort (bvh.h before vec16.h), and what it compiles
    src = tmp_path / "k.cl"
    src.write_text("""
inline int leaf_hit(__global const float16 *leaf, const float t) {
    const float16 u = leaf[0] - t, v = leaf[1];
    const int16 hit = (u >= 0.0f) & (v > t);
    float a[16];
    vstore8(u.lo, 0, a);
    return any(hit) + any(hit.lo) + (int)fmax(u.s3, 1.0f) + (int)sqrt(v.hi).s0
        + any(isgreater(leaf[2].lo, 0.0f)) + (int)fabs(leaf[3]).s1;
}
__kernel void k(__global float16 *out) { out[0] = log((float16)(1.0f)); }
""")
    fns, macros = _user_functions(str(tmp_path))
    calls = [c for _, c in wide_builtin_calls(str(src), fns, macros)]
    assert calls == ["any(hit)", "fabs(leaf[3])", "log((float16)(1.0f))"]


def test_the_self_test_launches_every_kernel_with_the_options_invrad_builds():
    from invrad_wb.core.inverse.votes import PROFILE_STEP_DEG
    programs = {os.path.splitext(f)[0] for f in os.listdir(C.KERNELS_DIR) if f.endswith(".cl")}
    assert {name for name, _ in probe.KERNEL_VARIANTS} == programs
    for name, options in probe.KERNEL_VARIANTS:
        if name == "votes_exact":
            assert f"-D PROFILE_STEP={PROFILE_STEP_DEG!r}f" in options


@pytest.mark.opencl
@pytest.mark.parametrize("split", [None, "1"], ids=["as_chosen", "split16"])
def test_every_kernel_builds_and_launches_on_this_driver(split):
    """The driver's own choice of kernels/vec16.h's branch, and the split one (PoCL from
    PyPI's) on any driver."""
    child = ("import sys; sys.path.insert(0, sys.argv[1])\n"
             "from invrad_wb.core.accel import probe\n"
             "from invrad_wb.core.accel.device import get_env\n"
             "print(len(probe.launch_every_kernel(get_env())))\n")
    env = dict(os.environ, **{probe.ENV_CHILD: "1"})
    if split:
        env[probe.ENV_SPLIT16] = split
    p = subprocess.run([sys.executable, "-c", child, str(ROOT)], env=env, capture_output=True,
                       text=True, timeout=probe.TIMEOUT_S, stdin=subprocess.DEVNULL)
    said = (p.stderr + p.stdout).strip().splitlines()
    assert p.returncode == 0, f"exit status {p.returncode}: " + "\n".join(said[-8:])
    assert said[-1] == str(len(probe.KERNEL_VARIANTS) + 1)    # radiosity holds two kernels


@pytest.mark.opencl
@pytest.mark.parametrize("name", ["votes_exact", "patch_form_factors", "segments_occluded"])
def test_split_built_ins_match_the_numpy_twins(name, monkeypatch):
    """kernels/vec16.h's split branch (what PoCL from PyPI builds) on this driver: the
    parity cases of test_accel (votes_exact, radiosity and bvh.h use the helpers)."""
    import test_accel
    from invrad_wb.core.accel.device import get_env
    from invrad_wb.core.accel.registry import pairs
    monkeypatch.setattr(get_env(), "base_options", ["-D INVRAD_SPLIT16=1"])
    args, kw, same = test_accel.CASES[name]()
    same(pairs()[name].numpy(*args, **kw), pairs()[name].opencl(*args, **kw))
