"""Bed (taler) drive of the two-revolution flat-bed press with a James differential (seed 004).

    motor (MotorBelt) <-pulley- flywheel (FlywheelShaft) -crank-> fourbar (FourBar O2ADO5) =ring=> diff
                                                        -aux---> cam (CamRocker, disc cam) -rocker-> diff.carrier
    diff (JamesDifferential) -sun-> bed (RackBed: pinion z6, rack, bed mass m_T)

* Four-bar O2ADO5 with the published relative lengths 1 : 1.91579 : 2.10526 : 2.25263 (crank 0.1 m, an
  assumed scale), synthesised for a 60 deg rocker swing and a 30 deg minimum transmission angle, assembled on
  the seed's branch (bed_law.SEED_BRANCH = -1 with the crank turning counter-clockwise): its working stroke
  has the small acceleration peak at the run-up (C1 3.113, C3 12.884), as the seed's.
* The disc cam on the same main shaft swings the carrier by 40 deg with the published rise / return phases
  216 deg 53' 10" / 143 deg 06' 50"; its rise starts with the four-bar's working stroke (both inputs leave their
  extreme positions together, as the seed requires), so the run starts there too (flywheel phi0).
* The carrier's rise law is the seed's: synthesised so that, summed with the four-bar through the
  differential, the bed moves uniformly through the printing zone (law 8, ``bed004``,
  fmus/physics/bed_law.py); its run-up share ``law_km`` is computed here from the zone and the stroke
  (``CARRIER_RUNUP``: the largest one whose uniform segment covers the zone).  The return is the seed's too
  (law 9, ``bed004r``): the carrier's law that, with the four-bar's idle stroke, returns the bed by the
  harmonic law (accelerated, no printing).  The harmonic K0 rise and return are ``--set cam.law=0
  --set cam.law_return=0``.
* The cam geometry meets the seed's largest pressure angle of 28 deg for these laws: designed with a 0.1 m
  follower arm, centre distance 0.141426 m, pitch base radius 0.082419 m (r0/S = 1.181; the seed's r0/S =
  0.95 on the pitch curve gives at best 29.9 deg); the seed's 0.95 holds for the working profile with a
  roller of 0.2306 S.  The numbers are bed_cam.design_cam(CARRIER_RUNUP) (4-9 s to compute, so recorded
  here; tests/test_bed_law.py checks that the synthesis gives them), scaled so that the cam centre to carrier
  pivot distance is the four-bar's frame O2O5 (both the rocker and the carrier turn about O5, the cams sit on
  O2): follower arm 0.14886 m, centre distance 0.210526 m.
* The cam is declared rigid (fidelity 0); its elastic levels (1, 2: the scenes' full model) get values for
  this drive, not the component defaults, which are the seed-000 feeder's (5000 N.m/rad and 5e5 N/m for a
  0.00043 kg.m2 rocker): against the bed's inertia reflected to the carrier, (1 + z3/z5)^2 * m_T * R6^2 =
  10 kg.m2, those put a 2.5-3.6 Hz mode into the carrier drive and doubled the follower swing.  Assumed: the
  transmission from the cam to the carrier (follower arm, shaft, carrier) is as stiff and as damped,
  reduced to its output, as the four-bar that drives the ring: coupler 5e7 N/m and 2e3 N.s/m times
  rocker_length^2 = 2.5e6 N.m/rad and 101 N.m.s/rad (about 14 % of critical for the 0.05 kg.m2 follower
  alone, 1 % for the follower with the reflected bed); roller contact stiffness 1e8 N/m (steel roller on
  the cam, a line contact of order 1e9 N/m, in series with the roller's bearing and pin); a groove cam's
  running play of 10 um at the roller (the carrier is driven both ways, so the cam must be form-closed).
* Differential z_ring/z_sun = 3 with 3 planets (seed: i_53^b = -3, i_5b^3 = 4).  The inputs add only when ring
  and carrier turn in opposite senses (seed: -w3 and +w_b); the four-bar rocker turns counter-clockwise on its
  working stroke, like the cam follower, so it drives the ring through a reversing pair, a parameter of the
  differential (``ring_sense = -1``: motion and torque reversed, power kept; ``ring_offset`` puts the ring at 0
  in the starting extreme position).  The bond rocker -> ring is a plain one, so every FMI importer computes
  the same machine (OMSimulator and CoFmuPy drop an SSP LinearTransformation on a connection).
* Bed: pinion z6 = 25 teeth, module 4 mm (R6 = 0.05 m, assumed), m_T = 250 kg (assumed: the seed gives no
  mass); stroke = R6 * alpha_Sigma with alpha_Sigma = 3*60 + 4*40 = 340 deg, about 0.297 m; a printing load of
  500 N acts on the forward stroke between 0.08 and 0.24 m.
* Main shaft at 60 rpm: a 4-pole motor (1425 rpm) through a reduction of 23.75 written as one belt ratio (the
  seed gives no drive data).
"""
import math

from fmus.physics import bed_law, fourbar, fourbar_synthesis
from harness.model import Experiment, Instance, System, bond
from harness.specs import (AccuracySpec, Answer, Belt, ChartSpec, Load, Panel, PrecisionSpec, QuantitySpec, Requirement,
                           Scene, Shaft, StabilitySpec, Zone)
from systems import blocked_jam_accuracy, blocking_jam, motor_inputs, motor_scenarios

RPM = 2 * math.pi / 60
CRANK, COUPLER, FRAME, ROCKER = 0.1, 0.191579, 0.210526, 0.225263  # m: seed 004 ratios x 0.1 m
C_COUPLER, D_COUPLER = 5e7, 2e3  # N/m, N.s/m: four-bar coupler (assumed); the cam transmission copies them
BRANCH = bed_law.SEED_BRANCH                                      # the seed's assembly of the four-bar
_analysis = fourbar_synthesis.stroke_angles(1.0, COUPLER / CRANK, FRAME / CRANK, ROCKER / CRANK, branch=BRANCH)
PHI_START = math.radians(_analysis.working_start_deg)  # crank angle where the working stroke begins
ROCKER_START = float(fourbar.position(PHI_START, CRANK, COUPLER, FRAME, ROCKER, BRANCH)[0])  # rad
PINION_RADIUS = 0.004 * 25 / 2                                  # m: module 4 mm, z6 = 25
PRINT_ZONE = (0.08, 0.24)                                       # m of bed travel on the working stroke
IN_ZONE = f'between(r["bed.bed.s"], {PRINT_ZONE[0]!r}, {PRINT_ZONE[1]!r}) & (r["bed.bed.v"] > 0)'  # qoi mask
BED_STROKE = PINION_RADIUS * (bed_law.SEED_RATIO * abs(bed_law.working_stroke().swing)
                              + (1 + bed_law.SEED_RATIO) * bed_law.SEED_CARRIER_SWING)   # m, about 0.297
CARRIER_RUNUP = bed_law.runup_for_zone(PRINT_ZONE[0] / BED_STROKE, PRINT_ZONE[1] / BED_STROKE)  # about 0.246
FULL_MODEL_STEP = 2e-4                                           # s: the scenes' full model (below)
CAM_DESIGN = (0.1, 0.1414255816, 0.0824194029)   # m: arm, distance, base radius of bed_cam.design_cam(CARRIER_RUNUP)
CAM_ARM, CAM_DISTANCE, CAM_BASE_RADIUS = (FRAME / CAM_DESIGN[1] * v for v in CAM_DESIGN)  # m: distance = O2O5

SYSTEM = System(
    name="bed_drive",
    description="Two-revolution flat-bed press: bed drive by four-bar + disc cam through a James differential "
                "and rack (seed 004)",
    instances=[
        Instance("motor", "MotorBelt", {
            "fidelity": 1, "P_rated": 2200.0, "w_rated": 1425.0 * RPM, "w_sync": 1500.0 * RPM,  # W, rad/s
            "breakdown_ratio": 2.2, "J_motor": 0.007,                                         # 1, kg.m2
            "d_motor_pulley": 0.04, "d_driven_pulley": 0.95,                                  # m: ratio 23.75
            "c_belt": 4.0e5, "d_belt": 400.0,                                                 # N/m, N.s/m
        }),
        Instance("flywheel", "FlywheelShaft", {
            "fidelity": 1, "J_flywheel": 8.0, "J_crank": 0.5,     # kg.m2
            "G": 8.1e10, "d": 0.06, "l": 0.8, "psi": 0.5,         # Pa, m, m, 1
            "w0": 60.0 * RPM, "phi0": PHI_START,                  # rad/s, rad
        }),
        Instance("fourbar", "FourBar", {
            "crank_length": CRANK, "coupler_length": COUPLER, "frame_length": FRAME, "rocker_length": ROCKER,
            "fidelity": 1, "coupler_stiffness": C_COUPLER, "coupler_damping": D_COUPLER,  # N/m, N.s/m
            "rocker_inertia": 0.5, "clearance": 0.0,                            # kg.m2 (ring gear z3 + rocker)
            "branch": BRANCH,
        }),
        Instance("cam", "CamRocker", {
            "mechanism": 1, "fidelity": 0,                           # disc cam, rigid
            "law": 8, "law_return": 9, "law_km": CARRIER_RUNUP,      # seed 004's carrier laws (bed004, bed004r)
            "follower_arm": CAM_ARM, "cam_distance": CAM_DISTANCE, "cam_base_radius": CAM_BASE_RADIUS,  # m
            "swing": math.radians(40.0), "phi_start": PHI_START,     # rad
            "rocker_inertia": 0.05,                                  # kg.m2 (carrier + follower)
            # fidelity 1, 2 (module docstring): transmission as the four-bar's, reduced to its output
            "stiffness": C_COUPLER * ROCKER ** 2, "damping": D_COUPLER * ROCKER ** 2,  # N.m/rad, N.m.s/rad
            "contact_stiffness": 1e8, "clearance": 10e-6,                            # N/m, m (roller)
        }),
        Instance("diff", "JamesDifferential", {"z_ring": 72, "z_planet": 24, "z_sun": 24, "n_planets": 3,
                                               "fidelity": 0,
                                               "ring_sense": -1, "ring_offset": ROCKER_START}),  # 1, rad
        Instance("bed", "RackBed", {
            "fidelity": 1, "m_T": 250.0, "module": 0.004, "z_pinion": 25,     # kg, m, teeth
            "c_mesh": 2.0e7,                  # N/m: rack mesh in series with the drive-train compliance
            "d_mesh": 0.2 * math.sqrt(2.0e7 * 250.0),  # N.s/m: 10 % of critical for the bed on that mesh
            "F_print": 500.0, "s_print_start": PRINT_ZONE[0], "s_print_end": PRINT_ZONE[1],  # N, m, m
        }),
    ],
    bonds=[
        bond("flywheel.pulley", "motor.pulley"),
        bond("flywheel.crank", "fourbar.crank"),
        bond("flywheel.aux", "cam.crank"),
        bond("fourbar.rocker", "diff.ring"),      # through the differential's reversing pair
        bond("cam.rocker", "diff.carrier"),
        bond("diff.sun", "bed.pinion"),
    ],
    # Linear extrapolation at 0.5 ms: against the monolithic reference (precision study, 0.15 s and 1 s)
    # every compared column is closer than with the zero-order hold at 0.2 ms, the run
    # takes 2.5 times fewer steps, and the step is half the coupling's stability limit at order 1 (1 ms)
    experiment=Experiment(stop_time=2.0, step=5e-4, master="jacobi", extrapolation=1),
    free_inputs=motor_inputs(),
    # The scenes' full model (every component at its highest level: the four-bar's and the cam's clearances, the
    # differential's mesh) keeps the 0.2 ms step: at 0.25 ms with linear extrapolation it diverges at 8 ms
    scenes=[
        Scene("bed_stroke", "What is the bed stroke?", 'ptp(window(r["bed.bed.s"], 0.0, 1.0))',
              tolerance=0.005, unit="m", stop_time=1.0, step=FULL_MODEL_STEP),
        Scene("print_speed_ripple", "How uniform is the bed speed inside the printing zone?",
              'ptp(window(r["bed.bed.v"], 0.25, 0.45))', tolerance=0.05, unit="m/s", stop_time=0.5,
              step=FULL_MODEL_STEP),
        Scene("peak_crank_torque", "What peak torque does the main shaft carry?",
              'peak(window(r["flywheel.shaft_torque"], 0.2, 1.0))', tolerance=0.05, unit="N.m", stop_time=1.0,
              step=FULL_MODEL_STEP),
    ],
    default_scene="print_speed_ripple",  # the seed's aim: a uniform bed speed while printing
    precision=PrecisionSpec("bed.bed.s", "bed position", "m", stop_time=0.15,
                            steps=(5e-5, 1e-4, 2e-4), tolerances=(1e-2, 1e-3),
                            columns=("flywheel.crank.w", "diff.ring.phi", "fourbar.crank.tau")),
    # Stability, measured with --quick (jacobi, order 0): the step limit hardly moves with the rack mesh (c_mesh
    # 5e6..1e8: 5.5e-4..6.3e-4 s), the coupler, shaft or belt stiffness (no change), but scales with the ring +
    # rocker inertia on the four-bar's motion OUTPUT side of the reversing pair (0.1 -> 1.3e-4 s, 0.5 -> 6.0e-4 s,
    # 2.5 -> 2.1e-3 s): the rigid differential hands the effort of the bed's side straight back, so the
    # inertia ratio across that FMU boundary sets the limit (the force-displacement coupling's mass ratio).
    stability=StabilitySpec(
        "fourbar.rocker_inertia", (0.1, 0.25, 0.5, 1.0, 2.5), (0.1, 0.5, 2.5), 0.1,
        lambda p: math.sqrt(p("fourbar.coupler_stiffness") * p("fourbar.rocker_length") ** 2
                            / p("fourbar.rocker_inertia")),
        "inertia of the ring gear and rocker [kg.m2] on the four-bar's motion-output port (FourBar), coupled "
        "through the rigid James differential to the bed; omega ~ sqrt(c_coupler l_rocker^2 / J_rocker)"),
    # The accuracy a press engineer asks of the drive (harness.studies.accuracy), over one turn of the main shaft:
    # the register (bed position while printing), the bed speed's uniformity there, the shaft's peak torque
    accuracy=AccuracySpec((
        Requirement("bed position in the printing zone", 'r["bed.bed.s"]', 10e-6, "m", where=IN_ZONE),
        Requirement("bed speed in the printing zone", 'r["bed.bed.v"]', 1e-3, "m/s", relative=True, where=IN_ZONE),
        Requirement("peak main-shaft torque", 'peak(r["flywheel.shaft_torque"])', 0.01, "N.m", relative=True),
    ), stop_time=1.0,
        # hosts that read outputs after the step and hold them (libcosim, Ecos): jacobi-sampled with hold meets
        # this at 0.1 ms (2.5 um, 0.038 %, 0.72 %, with the seed's mechanism) and diverges at 0.2 ms (the
        # effort through the rigid differential and cam arrives a step late); the exported SSP declares it
        # (tests/test_host_accuracy.py)
        sampled_host_step=1e-4),
    # The run chart (harness.reporting.charts): the seed's quantities over time and over one turn of the main shaft from
    # the start of the working stroke, the printing zone shaded where the bed is in it on the working stroke
    chart=ChartSpec(
        panels=(
            Panel("Bed position s", ("bed.bed.s",)),
            Panel("Bed speed v", ("bed.bed.v",)),
            Panel("Differential inputs: ring (four-bar rocker) and carrier (cam follower) angles",
                  ("fourbar.rocker.phi", "cam.rocker.phi"), ("ring: four-bar rocker", "carrier: cam follower")),
            Panel("Main shaft speed (crank side)", ("flywheel.crank.w",)),
            Panel("Torques on the main shaft", ("flywheel.shaft_torque", "fourbar.crank.tau", "cam.crank.tau"),
                  ("transmitted by the shaft", "four-bar crank", "disc cam")),
            Panel("Rack mesh force on the bed", ("bed.mesh_force",)),
            Panel("Motor torque", ("motor.motor_torque",)),
            Panel("Motor electrical power (+: drawn from the grid)", ("motor.power_electrical",)),
        ),
        zones=(Zone(f"printing zone: bed at {PRINT_ZONE[0]:g} to {PRINT_ZONE[1]:g} m on the working stroke", IN_ZONE),),
        crank_angle="flywheel.crank.phi", cycle_origin=PHI_START, origin_name="start of the working stroke"),
)

# The engineering quantities printed after a run (harness.reporting.quantities): over the steady turns of the main shaft
# from the start of the working stroke; the speed fluctuation on the crank side of the main shaft (the four-bar
# and the cam sit there), and on the flywheel and the motor for comparison (the belt and the shaft between them)
SYSTEM.quantities = QuantitySpec(
    shaft_angle="flywheel.crank.phi", shaft_speed="flywheel.crank.w",
    shaft_name="main shaft, crank side of the flywheel shaft (flywheel.crank.w)",
    cycle_origin=PHI_START, cycle_name="revolution of the main shaft from the start of the working stroke",
    motor="motor",
    loads=(
        Load("shaft_torque", "flywheel.shaft_torque", "torque the main shaft transmits from the flywheel"),
        Load("belt_torque", "motor.pulley.tau", "belt torque on the flywheel pulley"),
        Load("coupler_force", "fourbar.joint_force", "four-bar coupler force (joints A and D)"),
        Load("fourbar_clearance_force", "fourbar.contact_force", "contact force in the four-bar's clearance joint"),
        Load("cam_roller_force", "cam.pin_force", "cam roller contact force"),
        Load("cam_groove_force", "cam.groove_force", "cam roller force on the groove wall"),
        Load("differential_mesh_torque", "diff.mesh_torque", "differential's mesh torque on the sun shaft"),
        Load("rack_force", "bed.mesh_force", "pinion force on the bed's rack"),
    ),
    answers=(
        Answer("bed_speed_spread", "fluctuation", ("bed.bed.v",), "%",
               "(v_max - v_min) / v_mean of the bed through the printing zone, v_mean its time mean there; the "
               "largest over the steady cycles", where=IN_ZONE, scale=100.0),
        Answer("register_error", "register", ("bed.bed.s",), "um",
               "largest |s - s_uniform| of the bed through the printing zone, s_uniform the uniform motion "
               "through the zone's entry and exit", where=IN_ZONE, scale=1e6),
        Answer("speed_fluctuation_flywheel", "fluctuation", ("flywheel.pulley.w",), "%",
               "delta on the flywheel side of the main shaft (flywheel.pulley.w), w_mean the cycle's time mean",
               scale=100.0),
        Answer("speed_fluctuation_motor", "fluctuation", ("motor.motor_speed",), "%",
               "delta of the motor rotor (motor.motor_speed), w_mean the cycle's time mean", scale=100.0),
    ),
    # the main shaft's stress from its diameter; the belt's slip margin: three SPZ V-belts (assumed: the seed gives
    # no drive data), 500 N allowable tight-side force each, mu 0.3 in a 34 deg groove, 125.9 deg of wrap on the
    # 40 mm motor pulley at a 1 m centre distance (pi - 2 asin((0.95 - 0.04) / 2))
    shafts=(Shaft("shaft_torque", "flywheel.d"),),
    belts=(Belt("belt_torque", "motor.d_driven_pulley", tight_force=1500.0, mu=0.3, wrap=125.9, groove=34.0,
                source="three SPZ belts, assumed"),),
)

# The transients the drive is sized by (harness.scenarios): start-up from rest, a speed change through the supply
# frequency, an emergency stop with the rotor brake (the bed's overrun reported)
# The accuracy each question needs against the monolithic reference through the same events (study accuracy
# bed_drive --scenario NAME): the stop located to 2 ms and its angle to 0.5 %, the peak loads of the stop to 2 %
# and the crank speed through it to 0.02 rad/s (0.3 % of its 7.3 rad/s); measured on a stop at 0.5 s, jacobi order
# 1 at 0.5 ms: 0.2 ms, 0.018 %, 0.095 % (shaft), 0.0036 rad/s; at 1 ms and above jacobi and gauss-seidel diverge
SYSTEM.scenarios = motor_scenarios(SYSTEM, {"flywheel.w0": 0.0}, watch="bed.bed.s", accuracy={
    "estop": (
        Requirement("stopping time", "stopping_time", 2e-3, "s"),
        Requirement("stopping angle", "stopping_angle", 5e-3, "deg", relative=True),
        Requirement("peak main-shaft torque in the stop", "shaft_torque_peak", 0.02, "N.m", relative=True),
        Requirement("peak belt torque in the stop", "belt_torque_peak", 0.02, "N.m", relative=True),
        Requirement("crank speed through the stop", 'r["flywheel.crank.w"]', 0.02, "rad/s"),
    ),
})
# A jam that blocks the bed: at 1.0 s (the start of the second working stroke, the bed near 0 m) a foreign body
# wedges the bed at 0.16 m, the middle of the printing zone, and holds it (a catch): a stop 10 times as stiff as the
# rack mesh it acts in series with (2e8 N/m against c_mesh = 2e7; assumed), 10 % of the critical damping of the
# bed's mass on it (0.2 * sqrt(2e8 * m_T)).  Held at the bed, the drive does not come to rest: the stalled motor
# keeps the flywheel, crank and mechanism swinging against the rack mesh at about 12 Hz (the monolithic reference
# too; no belt slip is modelled, and the belt's slip margin in the jam is 0.19), so the run ends at its stop time
# (settle_limit) and the accuracy asks no load on a blocked drive
JAM_POSITION, JAM_STIFFNESS = 0.16, 2.0e8        # m, N/m
SYSTEM.scenarios.append(blocking_jam(SYSTEM, "bed", JAM_POSITION, JAM_STIFFNESS,
                                     0.2 * math.sqrt(JAM_STIFFNESS * SYSTEM.instance("bed").parameters["m_T"]),
                                     at=1.0, stop_time=2.0, settle_limit=2.0,
                                     what="a foreign body wedging the bed mid-print",
                                     accuracy=(*blocked_jam_accuracy("stop_force", held=False),
                                               Requirement("peak rack force in the jam", "rack_force_peak", 0.02,
                                                           "N", relative=True))))
