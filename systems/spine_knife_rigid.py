"""Knife drive of the book-block spine processing device as seed 003 states it: the motor "absolutely rigid".

    shaft (ParallelShafts, drive end held at 600 rpm: driving shaft S1 and driven shaft S2 in parallel, flywheel
    J1 on S2 fed by the V-belt, knife inertia J_red) -crank-> linkage (FourBar) -rocker-> knife (KnifeLoad)

The seed's dynamic model (Fig. 3, eq. (10)) takes the electric motor D as absolutely rigid: the drive end
phi0 turns uniformly whatever the load.  Here the shaft's drive end is that ideal speed source
(``rigid_drive = 1``: phi0'' = 0, no motor instance), so the shafts, the flywheel J1, the belt between the
flywheels and the knife are the seed's eq. (10) with the driven shaft's torque on the knife (docs/seed_003.md).
Everything else -- the cut, J_red by eq. (12), the shafts, J1, the flywheels' belt, the linkage, the knife --
is systems/spine_knife.py's.  systems/spine_knife.py is the variant with a motor on an elastic belt
(MotorBelt) turning a 0.2 kg.m2 flywheel at the drive end.
"""
import dataclasses

from harness.model import Experiment, Instance, System, bond
from systems import spine_knife as base

SHAFT = {**base.SYSTEM.instance("shaft").parameters, "rigid_drive": 1}

SYSTEM = System(
    name="spine_knife_rigid",
    description="Book-block spine knife drive as seed 003 states it: absolutely rigid drive end (600 rpm), "
                "two shafts in parallel with the flywheel J1 on a V-belt, parallelogram double crank, cutting load",
    instances=[
        Instance("shaft", "ParallelShafts", SHAFT),
        Instance("linkage", "FourBar", dict(base.SYSTEM.instance("linkage").parameters)),
        Instance("knife", "KnifeLoad", dict(base.KNIFE)),
    ],
    bonds=[
        bond("shaft.crank", "linkage.crank"),
        bond("linkage.rocker", "knife.knife"),
    ],
    experiment=Experiment(stop_time=0.5, step=5e-5, master="jacobi"),
    free_inputs={"shaft.pulley.tau": "the drive end is held at 600 rpm (rigid_drive = 1): a torque on it moves "
                                     "nothing",
                 "shaft.aux.tau": "the second take-off on the knife node drives nothing here: no torque on it"},
    scenes=list(base.SYSTEM.scenes),   # the belt variant's questions and its precision study
    precision=base.SYSTEM.precision,
    default_scene="shaft_twist",  # seed 003's question: torsional deformation and resonance of the knife shaft
)

# The engineering quantities and the run chart are the belt variant's, without its motor (no motor instance here)
SYSTEM.quantities = dataclasses.replace(
    base.SYSTEM.quantities, motor=None, belts=(),
    loads=tuple(load for load in base.SYSTEM.quantities.loads if not load.column.startswith("motor.")))
SYSTEM.chart = dataclasses.replace(
    base.SYSTEM.chart, panels=tuple(p for p in base.SYSTEM.chart.panels if not p.columns[0].startswith("motor.")))
