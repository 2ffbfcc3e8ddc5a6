"""Writes the photometric test files of this folder (our own making, analytic shapes).

* ``lambertian.ldt`` / ``lambertian.ies``: I = F / pi * cos(gamma), F = 1000 lm (EULUMDAT
  with rotational symmetry, IES LM-63-2002 with one horizontal angle);
* ``spot.ies``: I = F (n + 1) / (2 pi) cos^n(gamma), n = 10, F = 2000 lm (a narrow beam);
* ``asymmetric.ies``: I = F (n + 1) / (2 pi) cos^n(gamma) (1 + 0.5 cos C), n = 2,
  F = 1500 lm, 24 horizontal angles over 360 degrees (C = 0 twice as bright as C = 180 ...
  3 times, as 1.5 / 0.5);
* ``broken.ldt``: a truncated file that must not parse.

Run ``python tests/data/photometry/make_photometry.py`` to regenerate them.
"""
import math
import os

HERE = os.path.dirname(os.path.abspath(__file__))
GAMMAS = [5.0 * i for i in range(37)]           # 0..180


def cos_n(gamma_deg, n):
    c = math.cos(math.radians(gamma_deg))
    return c ** n if c > 0 else 0.0


def write_ldt(path, name, cd_per_klm, lamp_lm):
    """EULUMDAT, Isym 1 (symmetric about the vertical axis): one C plane stored."""
    lines = ["invrad tests", "1", "1", "36", "10", str(len(GAMMAS)), "5", "invrad-test-1",
             name, name, os.path.basename(path), "2026-11-24 invrad", "100", "0", "50",
             "100", "0", "0", "0", "0", "0", "100", "100", "1", "0", "1", "1", "LED",
             f"{lamp_lm:g}", "4000", "80", "10"]
    lines += ["0.5"] * 10                          # direct ratios k = 0.6 .. 5
    lines += [f"{10.0 * i:g}" for i in range(36)]   # C angles
    lines += [f"{g:g}" for g in GAMMAS]             # gamma angles
    lines += [f"{v:.4f}" for v in cd_per_klm]
    with open(path, "w", newline="\r\n") as fh:
        fh.write("\n".join(lines) + "\n")


def write_ies(path, name, cs, cd_rows, lamp_lm):
    """IES LM-63-2002, type C, absolute candela for a lamp of ``lamp_lm`` lumens."""
    head = ["IESNA:LM-63-2002", "[TEST] invrad analytic test distribution",
            "[MANUFAC] invrad tests", f"[LUMCAT] {name}", f"[LUMINAIRE] {name}",
            "[ISSUEDATE] 2026-11-24", "TILT=NONE",
            f"1 {lamp_lm:g} 1 {len(GAMMAS)} {len(cs)} 1 2 0.1 0.1 0.05", "1.0 1.0 10"]
    body = [" ".join(f"{g:g}" for g in GAMMAS), " ".join(f"{c:g}" for c in cs)]
    body += [" ".join(f"{v:.4f}" for v in row) for row in cd_rows]
    with open(path, "w") as fh:
        fh.write("\n".join(head + body) + "\n")


def main():
    lam = [1000.0 / math.pi * cos_n(g, 1) for g in GAMMAS]
    write_ldt(os.path.join(HERE, "lambertian.ldt"), "LAMB-1000", lam, 1000)   # cd/klm
    write_ies(os.path.join(HERE, "lambertian.ies"), "LAMB-1000", [0.0], [lam], 1000)
    n, f = 10, 2000.0
    spot = [f * (n + 1) / (2 * math.pi) * cos_n(g, n) for g in GAMMAS]
    write_ies(os.path.join(HERE, "spot.ies"), "SPOT-2000", [0.0], [spot], f)
    n, f = 2, 1500.0
    cs = [15.0 * i for i in range(25)]              # 0..360
    rows = [[f * (n + 1) / (2 * math.pi) * cos_n(g, n) * (1 + 0.5 * math.cos(math.radians(c)))
             for g in GAMMAS] for c in cs]
    write_ies(os.path.join(HERE, "asymmetric.ies"), "ASYM-1500", cs, rows, f)
    with open(os.path.join(HERE, "lambertian.ldt")) as src, \
            open(os.path.join(HERE, "broken.ldt"), "w") as dst:
        dst.write("".join(src.readlines()[:30]))


if __name__ == "__main__":
    main()
