"""The committed standard runs (fmus/docs/<name>/reference.csv, packed into each FMU) are the model's as it is now.

A physics change that moves a standard run fails here until its references are rewritten, deliberately, with
``python -m fmus.reference --write`` and committed with the change (docs/contributing.md).  The comparison is
exact but for one unit in the last digit the file writes (a libm elsewhere may round a last bit otherwise).
"""
from __future__ import annotations

import pytest

from fmus import reference


@pytest.mark.parametrize("name", reference.components())
def test_every_reference_csv_is_its_scripts_standard_run_now(name):
    path, text, fmt = reference.fresh(name)
    why = reference.difference(path.read_text(encoding="utf-8"), text, fmt)
    assert why is None, f"{path}: {why}; if the change is meant: python -m fmus.reference --write {name}"


def test_the_comparison_allows_the_last_digit_and_nothing_more():
    head = "time,y\n"
    committed = head + "0,1.2345\n0.1,-2\n"
    assert reference.difference(committed, committed, "%.5g") is None
    assert reference.difference(committed, head + "0,1.2346\n0.1,-2\n", "%.5g") is None     # last digit
    why = reference.difference(committed, head + "0,1.2347\n0.1,-2\n", "%.5g")              # two in the last
    assert why is not None and why.startswith("y at t = 0: committed 1.2345, now 1.2347"), why
    assert "columns differ" in reference.difference(committed, "time,y,z\n0,1.2345,0\n0.1,-2,0\n", "%.5g")
    assert "2 rows committed, 1 now" == reference.difference(committed, head + "0,1.2345\n", "%.5g")
    with pytest.raises(ValueError, match="is not %"):
        reference.digits("%.5f")


def test_the_command_names_an_unknown_component(capsys):
    assert reference.main(["no_such_part"]) == 2
    assert "unknown component(s) no_such_part (allowed: cam_rocker," in capsys.readouterr().err
