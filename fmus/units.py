"""FMI unit definitions: every unit the toolkit's FMUs use, as exponents of SI base units.

Pure data (no FMI import), shared by the FMU layer (UnitDefinitions) and the harness (unit checks).
"""
from __future__ import annotations

# unit name -> exponents of the base units (kg, m, s, A, K, mol, cd, rad); missing = 0
BASE_UNITS: dict[str, dict[str, int]] = {
    "1": {},
    "rad": {"rad": 1},
    "rad/s": {"rad": 1, "s": -1},
    "rad/s2": {"rad": 1, "s": -2},
    "N.m": {"kg": 1, "m": 2, "s": -2},
    "m": {"m": 1},
    "m/s": {"m": 1, "s": -1},
    "m/s2": {"m": 1, "s": -2},
    "N": {"kg": 1, "m": 1, "s": -2},
    "kg": {"kg": 1},
    "kg.m2": {"kg": 1, "m": 2},
    "N.m/rad": {"kg": 1, "m": 2, "s": -2, "rad": -1},
    "N/m": {"kg": 1, "s": -2},
    "N.m.s/rad": {"kg": 1, "m": 2, "s": -1, "rad": -1},
    "N.s/m": {"kg": 1, "s": -1},
    "s": {"s": 1},
    "W": {"kg": 1, "m": 2, "s": -3},
    "J": {"kg": 1, "m": 2, "s": -2},
    "Pa": {"kg": 1, "m": -1, "s": -2},
    "Hz": {"s": -1},
    "V": {"kg": 1, "m": 2, "s": -3, "A": -1},
    "A": {"A": 1},
}


def check_unit(name: str) -> str:
    if name not in BASE_UNITS:
        raise KeyError(f"unit {name!r} is not defined in fmus.units.BASE_UNITS")
    return name
