"""The bed drive of systems/bed_drive.py with a combined clutch-brake on its main shaft (seed 004's press; the
clutch-brake is the option presses stop by: ../shared/reference/press-engineering-facts.md, "Stopping").

    motor (MotorBelt) <-pulley- flywheel (ClutchBrakeShaft) -crank-> fourbar ... (as bed_drive)

The flywheel shaft carries a clutch-brake between the flywheel and the crank side (ClutchBrakeShaft,
fmus/physics/clutch_brake.py): its ``estop`` opens the clutch (the flywheel, belt and motor run on, the motor
switched off) and brakes the crank side alone with 300 N.m (assumed: about the main shaft's running peak,
281 N.m), 30 ms after the command (a pneumatic clutch-brake's response, assumed).  Everything else is the bed
drive's: its parts, method, quantities and charts; the motor's rotor brake stays released.
"""
import dataclasses

from harness.model import Instance, System
from harness.specs import Change, Scenario
from systems import bed_drive as base
from systems import motor_inputs, stop_accuracy

CLUTCH_BRAKE = {"cb_torque": 300.0, "cb_delay": 0.03}       # N.m, s (assumed)

SYSTEM = System(
    name="bed_drive_clutch",
    description="Two-revolution flat-bed press (seed 004) with a combined clutch-brake on its main shaft: the "
                "bed drive stopped on the crank side",
    instances=[Instance("flywheel", "ClutchBrakeShaft", {**base.SYSTEM.instance("flywheel").parameters,
                                                         **CLUTCH_BRAKE})
               if inst.name == "flywheel" else Instance(inst.name, inst.fmu, dict(inst.parameters))
               for inst in base.SYSTEM.instances],
    bonds=list(base.SYSTEM.bonds),
    experiment=base.SYSTEM.experiment,
    free_inputs={**motor_inputs(),
                 "flywheel.clutch_brake": "the clutch-brake's command: 0 (clutch closed, brake released) unless a "
                                          "scenario stops the press"},
    # the bed drive's questions: with the clutch closed the drive is the bed drive's, bit for bit
    # (tests/test_clutch_brake.py), so its scenes are answered there (tests/test_scenes.py runs them once)
    scenes=list(base.SYSTEM.scenes),
    default_scene=base.SYSTEM.default_scene,
)
SYSTEM.chart = base.SYSTEM.chart
# with the clutch closed the drive is the bed drive, so its precision question is the bed drive's
SYSTEM.precision = base.SYSTEM.precision
SYSTEM.quantities = dataclasses.replace(
    base.SYSTEM.quantities,
    brakes=(("clutch_brake", "flywheel.clutch_brake_torque", "flywheel.crank.w", "the clutch-brake on the main "
             "shaft"),))
# The emergency stop by the clutch-brake: at 1.5 s the motor switched off and the clutch-brake commanded
SYSTEM.scenarios = [Scenario(
    "estop", "How long and how far does the press run on after an emergency stop by its clutch-brake (motor off, "
    "the clutch open and 300 N.m on the crank side after 30 ms), and what loads does the stop put on the parts?",
    "stop", 3.0, (Change(1.5, "motor.supply", 0.0), Change(1.5, "flywheel.clutch_brake", 1.0)),
    watch="bed.bed.s", accuracy=stop_accuracy("bed.bed.s", (5e-4, "m")))]
