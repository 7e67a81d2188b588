"""The cheapest method measured for each scenario (docs/howto/transients.md's table) meets the accuracy the
scenario declares against the monolithic reference through the same events."""
from __future__ import annotations

import pytest

from harness import load
from harness.studies.accuracy import search_scenario

MEASURED = [  # (drive, scenario, master, order, step): the cheapest of the ladder the page shows
    ("spine_knife", "jam", "jacobi", 1, 2e-4),
    ("spine_knife", "startup", "jacobi", 1, 5e-4),
    ("spine_knife", "estop", "jacobi", 1, 5e-4),
    ("spine_knife", "speed_change", "jacobi", 1, 5e-4),
    ("trimmer_conveyor", "startup", "jacobi", 1, 1e-3),
    ("trimmer_conveyor", "speed_change", "jacobi", 1, 1e-3),
    ("trimmer_conveyor", "estop", "jacobi", 1, 5e-4),
    ("feeder_gto52", "startup", "jacobi", 1, 1e-3),
    ("feeder_gto52", "estop", "jacobi", 1, 5e-4),
    ("feeder_gto52", "jam", "jacobi", 1, 2e-4),
    ("feeder_gto52", "speed_change", "jacobi", 1, 2e-4),
    ("bed_drive", "startup", "jacobi", 1, 5e-4),
    ("bed_drive", "speed_change", "jacobi", 1, 5e-4),
    ("bed_drive", "jam", "jacobi", 1, 5e-4),
    ("proof_press", "startup", "jacobi", 1, 1e-3),
    ("proof_press", "estop", "jacobi", 1, 1e-3),
    ("proof_press", "speed_change", "jacobi", 1, 5e-4),
]


@pytest.mark.slow
@pytest.mark.parametrize("drive, scenario, master, order, step", MEASURED)
def test_the_measured_method_meets_the_scenarios_declared_accuracy(drive, scenario, master, order, step):
    system = load(drive)
    table = search_scenario(system, scenario, methods=((master, order),), steps=(step,))
    assert len(table) == 1 and bool(table["meets"].iloc[0]), table.to_dict("records")
