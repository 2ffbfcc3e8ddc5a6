"""The deep-dimming note of a designed room (luminaires below ``DEEP_DIMMING`` of their
rated output) and what the catalogue's smaller types would trade."""
import math

from invrad_wb.constants import DEEP_DIMMING


def _pct(fraction):
    """An output below ``DEEP_DIMMING`` in per cent, as printed: whole per cent, or one
    decimal (rounded down) where the whole number would read as the threshold itself
    ('49.7 %', not '50 %' in a note about outputs below 50 %)."""
    p = 100.0 * fraction
    if round(p) < 100.0 * DEEP_DIMMING:
        return f"{p:.0f}"
    return f"{math.floor(p * 10.0) / 10.0:.1f}"


def deep_dimming_note(rd, entries=None):
    """The deep-dimming note of a room: how many general luminaires of each type run below
    ``DEEP_DIMMING`` (each luminaire's own output), e.g. '9 of 15 DL-3500 run below 50 %
    (10 to 46 %)', the installed against the drawn power, and, given the room's catalogue
    ``entries``, what a smaller type would trade: the catalogue's types with fewer rated
    watts, and whether they are as efficient (lm/W) as the dimmed type (the design minimises
    the power drawn, so a less efficient smaller type cuts the installed power and draws
    more)."""
    x = rd.general_outputs()
    types = [lum.extra.get("type") for lum in rd.luminaires[:len(x)]]
    parts, trades = [], []
    for t, (low, n) in sorted(rd.deep_dimmed().items()):
        lows = [v for v, u in zip(x, types) if u == t and v < DEEP_DIMMING - 1e-9]
        lo, hi = _pct(min(lows)), _pct(max(lows))
        at = f"at {lo} %" if lo == hi else f"at {lo} to {hi} %"
        parts.append(f"the {t} {at}" if n == 1 else f"all {n} {t} {at}" if low == n
                     else f"{low} of {n} {t} {at}")
        if entries is not None:
            trades.append(_smaller_types_text(t, entries))
    head = (f"deep dimming: {'; '.join(parts)} of the rated output (below"
            f" {100 * DEEP_DIMMING:.0f} %); installed {rd.rated_watts:.0f} W for"
            f" {rd.watts:.0f} W drawn")
    if entries is None:
        return head + (": a smaller type (fewer rated watts) would be the better choice"
                       " where the catalogue has one")
    return head + ": " + "; ".join(trades)


def _smaller_types_text(name, entries):
    """What the catalogue offers instead of the deeply dimmed type ``name``."""
    own = next((e for e in entries if e.name == name), None)
    if own is None:
        return f"{name} is not in the room's catalogue"
    smaller = sorted({e.name: e for e in entries
                      if e.watts < own.watts - 1e-9 and not e.aimable}.values(),
                     key=lambda e: e.watts)
    if not smaller:
        return (f"the room's catalogue has no type with fewer rated watts than {name}"
                f" ({own.watts:g} W): a smaller one would cut the installed power")
    listed = ", ".join(f"{e.name} ({e.watts:g} W, {e.efficacy:.0f} lm/W)" for e in smaller)
    as_good = [e for e in smaller if e.efficacy >= own.efficacy - 1e-9]
    if not as_good:
        return (f"the catalogue's smaller types, {listed}, are less efficient than {name}"
                f" ({own.efficacy:.0f} lm/W): they would cut the installed power and draw"
                " more (the design minimises the power drawn)")
    return (f"of the catalogue's smaller types, {listed}, "
            f"{', '.join(e.name for e in as_good)} {'is' if len(as_good) == 1 else 'are'}"
            f" as efficient as {name} ({own.efficacy:.0f} lm/W) with fewer rated watts:"
            " the design kept the type that met every requirement for the least power"
            " drawn")
