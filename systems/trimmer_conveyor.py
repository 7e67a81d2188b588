"""Belt conveyors of a non-stop book-block trimmer (seed 003, second article: P. V. Topolnytskyi).

    motor (MotorBelt, ideal speed source) <-pulley- drive (FlywheelShaft: drive pulley, shaft, the conveyors'
    pulley, belts and blocks reduced to it) -crank-> trim (ConveyorLoad: head and tail knives)

* The article's test conditions: blocks at a 500 mm pitch, a 1200 mm tool, head and tail trimmed at once;
  this system is its Fig. 1 case, the 320x450x36 mm coated block with a 320 mm cut, at 1.8 m/s (one of its
  speeds 0.5, 1.0, 1.8, 2.7 m/s).  The article's results are not in our copy: the load is the toolkit's
  cutting-work model (fmus/docs/conveyor_load/index.md), specific cutting work 2.5e4 J/m2 (an order of
  magnitude), the whole tool cutting.  The sweep over the article's grid is systems/studies/conveyor_grid.yaml.
* Assumed, the article gives none: conveyor drive pulley r = 50 mm; a motor of 1425 rpm through a belt, the
  driven pulley sized for the belt speed (d = 0.1 m * w_motor * r / V); the drive's shaft steel 50 mm x 0.6 m;
  0.05 kg.m2 on the motor side (pulley), 0.1 kg.m2 on the conveyor side (pulley, belts and three blocks of
  about 5.7 kg, 5.7*3*0.05^2 = 0.043, rounded up).
* The blocks stream from the start (the first at the end of the cutting zone, x0 = zone + cut length), and
  the scenes read four whole pitches after the belts' start-up transient, so a mean is the pitch's mean.
"""
import math

from harness.model import Experiment, Instance, System, bond
from harness.specs import AccuracySpec, Answer, ChartSpec, Load, Panel, PrecisionSpec, QuantitySpec, Requirement, Scene, Zone
from systems import motor_inputs, motor_scenarios

RPM = 2 * math.pi / 60
SPEED = 1.8                                   # m/s, transport speed
R_PULLEY = 0.05                               # m, conveyor drive pulley
W_MOTOR = 1425.0 * RPM                        # rad/s
W_DRIVE = SPEED / R_PULLEY                    # rad/s, conveyor drive shaft
PITCH, ZONE, CUT = 0.5, 1.2, 0.32             # m
T_PITCH = PITCH / SPEED                       # s, one block
WINDOW = (0.1, round(0.1 + 4 * T_PITCH, 4))   # s: four whole pitches after the belts' start-up transient
ONE_PITCH = (0.1, 0.1 + T_PITCH)              # s: the first whole pitch after it

SYSTEM = System(
    name="trimmer_conveyor",
    description="Belt conveyors of a non-stop book-block trimmer: rigid motor, V-belt, drive shaft, "
                "transport load of head and tail trimming (seed 003, second article)",
    instances=[
        Instance("motor", "MotorBelt", {
            "fidelity": 0, "w_rated": W_MOTOR, "w_sync": 1500.0 * RPM,          # rad/s
            "d_motor_pulley": 0.1, "d_driven_pulley": 0.1 * W_MOTOR / W_DRIVE,  # m: belt ratio for SPEED
            "c_belt": 2.0e5, "d_belt": 300.0,                                    # N/m, N.s/m
        }),
        Instance("drive", "FlywheelShaft", {
            "fidelity": 1, "J_flywheel": 0.05, "J_crank": 0.1,                  # kg.m2
            "G": 8.1e10, "d": 0.05, "l": 0.6, "psi": 0.5,                         # Pa, m, m, 1
            "w0": W_DRIVE,                                                        # rad/s
        }),
        Instance("trim", "ConveyorLoad", {
            "w_cut": 2.5e4, "thickness": 0.036, "cut_length": 0.32,             # J/m2, m, m
            "pitch": PITCH, "tool_length": 1.2, "zone": ZONE, "knives": 2,      # m, m, m, 1
            "r_pulley": R_PULLEY, "x0": ZONE + CUT,                               # m: a steady stream from t = 0
        }),
    ],
    bonds=[
        bond("drive.pulley", "motor.pulley"),
        bond("drive.crank", "trim.shaft"),
    ],
    # the knives' load at 25 base steps (12.5 ms), everything else at 0.5 ms: the cheapest rates that meet the
    # accuracy below (python -m benchmarks.multirate: 0.68 of the FMU steps and 0.55 of the stepping CPU time of
    # every FMU at 0.5 ms, the largest single step that meets it; docs/performance.md)
    experiment=Experiment(stop_time=WINDOW[1], step=5e-4, master="jacobi", rates={"trim": 25}),
    free_inputs={**motor_inputs(),
                 "drive.aux.tau": "the drive shaft's second take-off drives nothing here: no torque on it"},
    scenes=[
        Scene("mean_moment", "What mean moment does trimming put on the conveyors' drive shaft?",
              'mean(window(r["trim.shaft.tau"], %g, %g))' % WINDOW, tolerance=0.01, unit="N.m"),
        Scene("peak_moment", "What peak moment does the drive shaft carry?",
              'peak(window(r["drive.shaft_torque"], %g, %g))' % WINDOW, tolerance=0.02, unit="N.m"),
    ],
    # The accuracy a designer of the conveyors' drive asks (harness.studies.accuracy), over one pitch after the
    # start-up: the article's quantity, the mean moment trimming puts on the drive shaft (what sizes the motor),
    # to 1 %, and the shaft's peak torque (what sizes the shaft) to 1 %
    accuracy=AccuracySpec((
        Requirement("mean trimming moment on the drive shaft", 'mean(window(r["trim.shaft.tau"], %r, %r))' % ONE_PITCH,
                    0.01, "N.m", relative=True),
        Requirement("peak drive-shaft torque", 'peak(window(r["drive.shaft_torque"], %r, %r))' % ONE_PITCH, 0.01,
                    "N.m", relative=True),
    ), stop_time=0.4,
        # hosts that read outputs after the step and hold them (libcosim, Ecos, FMPy): jacobi-sampled with hold
        # meets this at 0.5 ms, the ladder's largest (mean 0.007 %, peak 0.63 %), the experiment's step too
        # (harness.ssp.host_step; tests/test_host_accuracy.py)
        sampled_host_step=5e-4),
    default_scene="mean_moment",  # the article's quantity: the moment on the drive shaft (its Fig. 1)
    precision=PrecisionSpec("trim.shaft.tau", "moment on the drive shaft", "N.m", stop_time=0.6,
                            steps=(2e-4, 4e-4, 8e-4, 1.6e-3), columns=("drive.crank.w", "drive.shaft_twist")),
)

# The engineering quantities printed after a run (harness.reporting.quantities): one machine cycle is one block pitch of
# the conveyors (PITCH / R_PULLEY of the drive shaft's angle); the article's quantity, the trimming moment
SYSTEM.quantities = QuantitySpec(
    shaft_angle="drive.crank.phi", shaft_speed="drive.crank.w",
    shaft_name="conveyors' drive shaft, conveyor side (drive.crank.w)",
    cycle_angle=PITCH / R_PULLEY, cycle_name=f"one block pitch ({PITCH:g} m of belt travel)", motor="motor",
    loads=(
        Load("shaft_torque", "drive.shaft_torque", "torque the drive shaft transmits to the conveyors"),
        Load("belt_torque", "motor.pulley.tau", "belt torque on the drive pulley"),
    ),
    answers=(
        Answer("trimming_moment_mean", "mean", ("trim.shaft.tau",), "N.m",
               "time mean of the moment trimming and transport put on the drive shaft (negative: a load)"),
        Answer("trimming_moment_peak", "peak", ("trim.shaft.tau",), "N.m",
               "largest |moment| trimming and transport put on the drive shaft"),
        Answer("transport_force_peak", "peak", ("trim.transport_force",), "N",
               "largest transport force of the blocks through the trimming section"),
    ),
)

# The run chart (harness.reporting.charts): over one block pitch in machine degrees (360 per pitch), shaded where a fourth
# block's edge is in the cutting zone with the other three
SYSTEM.chart = ChartSpec(
    panels=(
        Panel("Trimming moment on the drive shaft (- : a load)", ("trim.shaft.tau",)),
        Panel("Transport force of the blocks", ("trim.transport_force",)),
        Panel("Drive-shaft torque (+: drives the conveyors)", ("drive.shaft_torque",)),
        Panel("Drive-shaft speed (conveyor side)", ("drive.crank.w",)),
        Panel("Motor electrical power (+: drawn from the grid)", ("motor.power_electrical",)),
    ),
    zones=(Zone("trimming four blocks at once", 'r["trim.blocks_cut"] >= 4'),),
    crank_angle="drive.crank.phi", cycle_angle=PITCH / R_PULLEY, origin_name="start of the run")

# The transients the conveyors' drive is sized by (harness.scenarios), with the motor at fidelity 1: start-up,
# speed change, emergency stop
SYSTEM.scenarios = motor_scenarios(SYSTEM, {"drive.w0": 0.0})
