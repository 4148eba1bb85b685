"""The constants each satellite system defines for its broadcast orbits, and the signal read from each.

==========  ================  ===================  =======================  ================================
system      GM (m^3/s^2)      Earth rate (rad/s)   code read, frequency     source
==========  ================  ===================  =======================  ================================
GPS ``G``   3.986005e14       7.2921151467e-5      L1 C/A, 1575.42 MHz      IS-GPS-200 N, 20.3.3.4.3
Galileo E   3.986004418e14    7.2921151467e-5      E1, 1575.42 MHz          Galileo OS SIS ICD 2.0, 5.1.1
BeiDou C    3.986004418e14    7.292115e-5          B1I, 1561.098 MHz        BDS-SIS-ICD-B1I 3.0, 5.2.4.11
QZSS J      3.986005e14       7.2921151467e-5      L1 C/A, 1575.42 MHz      IS-QZSS-PNT, 5.2 (as GPS)
==========  ================  ===================  =======================  ================================

The pseudorange codes are tried in the order given (RINEX 3 names): the first present in a file is used.
"""

from __future__ import annotations

from dataclasses import dataclass

from chronofuse.validation import InputError

__all__ = ["SystemConstants", "SYSTEM_CONSTANTS", "SYSTEM_NAMES", "parse_systems", "system_names"]


@dataclass(frozen=True)
class SystemConstants:
    """One system's broadcast-orbit constants and the pseudorange read from it."""

    letter: str
    name: str
    gm_m3_per_s2: float
    omega_e_rad_per_s: float
    frequency_hz: float
    codes: tuple[str, ...]


SYSTEM_CONSTANTS = {
    "G": SystemConstants("G", "gps", 3.986005e14, 7.2921151467e-5, 1575.42e6, ("C1C", "C1W", "C1P", "C1X")),
    "E": SystemConstants("E", "gal", 3.986004418e14, 7.2921151467e-5, 1575.42e6, ("C1C", "C1X", "C1B")),
    "C": SystemConstants("C", "bds", 3.986004418e14, 7.292115e-5, 1561.098e6, ("C2I", "C2X", "C2Q")),
    "J": SystemConstants("J", "qzss", 3.986005e14, 7.2921151467e-5, 1575.42e6, ("C1C", "C1X")),
}

#: Command-line names of the systems.
SYSTEM_NAMES = {c.name: c.letter for c in SYSTEM_CONSTANTS.values()}


def parse_systems(text: str) -> tuple[str, ...]:
    """``"gps+bds"`` -> ``("G", "C")``: system names joined by ``+`` (gps, gal, bds, qzss), GPS first when
    present (its clock is the reference). Raises :class:`~chronofuse.validation.InputError` naming the field."""
    names = [t.strip().lower() for t in str(text).split("+")]
    unknown = [n for n in names if n not in SYSTEM_NAMES]
    if unknown or not names:
        raise InputError(f"{{systems}} == {text!r}, must be names among {sorted(SYSTEM_NAMES)} joined by '+'",
                         fields=("systems",))
    letters = [SYSTEM_NAMES[n] for n in names]
    twice = sorted({n for n, letter in zip(names, letters) if letters.count(letter) > 1})
    if twice:
        raise InputError(f"{{systems}} == {text!r} names {', '.join(twice)} twice: each system once",
                         fields=("systems",))
    return tuple(sorted(letters, key="GECJ".index))


def system_names(letters) -> str:
    """``("G", "C")`` -> ``"gps+bds"``: the canonical lower-case names :func:`parse_systems` reads."""
    name_of = {}
    for name, letter in SYSTEM_NAMES.items():
        name_of.setdefault(letter, name)
    return "+".join(name_of[s] for s in letters)
