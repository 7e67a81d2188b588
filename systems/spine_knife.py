"""Knife drive of the book-block spine processing device, discrete-tangential method (seed 003).

    motor (MotorBelt, ideal speed source) <-pulley- shaft (FlywheelShaft: flywheel J1, driving shaft S1,
    knife-side inertia) -crank-> linkage (FourBar, parallelogram double crank) -rocker-> knife (KnifeLoad)

* The seed's motor is "absolutely rigid": MotorBelt at fidelity 0 (ideal speed source) with the V-belt.
* Driving shaft S1: steel, d = 30 mm, l = 0.3 m, c1 = G*pi*d^4/(32*l) = 2.15e4 N.m/rad (the seed asks for
  C_red > 2e4 N.m/rad); dissipation coefficient psi = 0.5 (seed: mu_red = 0.5).
* Knife-side inertia J_red = 5.4e-4 kg.m2, chosen so that the torsional natural frequency
  sqrt(c1/J_red)/(2*pi) is about 1000 Hz, inside the seed's recommended 800-1200 Hz (check it with
  ``python -m harness synth knife``).
* Parallelogram linkage with equal cranks R = 50 mm (seed: double crank with equal cranks; the belt between
  the crank shafts keeps it from flipping into an antiparallelogram, modelled by taking the parallelogram
  branch).  Its elastic levels (1, 2: the scenes' full model) have the belt as an element: the seed gives
  no c2, b2, so a V-belt like the motor belt here (2e5 N/m, 300 N.s/m along the pitch line) on equal
  pulleys of 0.1 m pitch diameter is assumed, c2 = 2e5*0.05^2 = 500 N.m/rad, b2 = 300*0.05^2 = 0.75
  N.m.s/rad.  Without it the cut, which ends at the dead point pi, stops the rocker there and the linkage
  runs on as an antiparallelogram (rocker backwards).  Coupler: 5e7 N/m (assumed), axial damping 141 N.s/m
  = 5 % of critical for the rocker inertia reduced to the coupler at the full arm R (2*0.05*sqrt(c*J)/R).
* Cutting load: feed-force samples 150/260/280/120 N over T_cut = 25 ms, cut over crank angles [pi/2, pi],
  one plunge per turn: the crank turns at 600 rpm (T_pause/T_cut = 3 > 2.5, the seed's rule).  The
  samples are assumptions: the seed prints none.
"""
import math

from harness.model import Experiment, Instance, System, bond
from harness.specs import PrecisionSpec, Scene, StabilitySpec

RPM = 2 * math.pi / 60
W_CRANK = 600.0 * RPM

SYSTEM = System(
    name="spine_knife",
    description="Book-block spine knife drive: rigid motor, V-belt, flywheel, compliant shaft, parallelogram "
                "double crank, cutting load (seed 003)",
    instances=[
        Instance("motor", "MotorBelt", {
            "fidelity": 0, "w_rated": 1425.0 * RPM, "w_sync": 1500.0 * RPM,   # rad/s
            "d_motor_pulley": 0.1, "d_driven_pulley": 0.2375,                 # m: ratio 2.375 -> 600 rpm
            "c_belt": 2.0e5, "d_belt": 300.0,                                 # N/m, N.s/m
        }),
        Instance("shaft", "FlywheelShaft", {
            "fidelity": 1, "J_flywheel": 0.2, "J_crank": 5.4e-4,            # kg.m2: J1, J_red
            "G": 8.1e10, "d": 0.03, "l": 0.3, "psi": 0.5,                    # Pa, m, m, 1
            "w0": W_CRANK,                                                    # rad/s
        }),
        Instance("linkage", "FourBar", {
            "crank_length": 0.05, "coupler_length": 0.2, "rocker_length": 0.05, "frame_length": 0.2,  # m
            "fidelity": 0, "rocker_inertia": 1e-4, "coupler_stiffness": 5e7, "clearance": 0.0,  # kg.m2, N/m, m
            "coupler_damping": 2 * 0.05 * math.sqrt(5e7 * 1e-4) / 0.05,                      # N.s/m
            "belt_stiffness": 2.0e5 * 0.05 ** 2, "belt_damping": 300.0 * 0.05 ** 2,        # N.m/rad, N.m.s/rad
        }),
        Instance("knife", "KnifeLoad", {
            "T_cut": 0.025, "F_T1": 150.0, "F_T2": 260.0, "F_T3": 280.0, "F_T4": 120.0,   # s, N
            "R": 0.05, "phi_s": math.pi / 2,                                              # m, rad
        }),
    ],
    bonds=[
        bond("shaft.pulley", "motor.pulley"),
        bond("shaft.crank", "linkage.crank"),
        bond("linkage.rocker", "knife.knife"),
    ],
    experiment=Experiment(stop_time=0.5, step=5e-5, master="jacobi"),
    scenes=[
        Scene("shaft_twist", "How large is the torsional deformation of the knife shaft?",
              'peak(window(r["shaft.shaft_twist"], 0.1, 0.3))', tolerance=0.05, unit="rad", stop_time=0.3),
        Scene("knife_torque", "What peak torque does the cutting put on the drive?",
              'peak(window(r["knife.knife.tau"], 0.1, 0.3))', tolerance=0.02, unit="N.m", stop_time=0.3),
    ],
    default_scene="shaft_twist",  # seed 003's question: torsional deformation and resonance of the knife shaft
    precision=PrecisionSpec("knife.knife.tau", "knife torque", "N.m", stop_time=0.1,
                            steps=(5e-5, 1e-4, 2e-4, 4e-4), columns=("shaft.crank.w", "shaft.shaft_twist")),
    stability=StabilitySpec(
        "shaft.d", (0.02, 0.025, 0.03, 0.04, 0.05), (0.02, 0.03, 0.05), 0.05,
        lambda p: math.sqrt(p("shaft.G") * math.pi * p("shaft.d") ** 4 / (32.0 * p("shaft.l"))
                            * (1.0 / p("shaft.J_flywheel") + 1.0 / p("shaft.J_crank"))),
        "driving-shaft diameter d [m] (torsional stiffness G pi d^4 / (32 l)) of the FlywheelShaft that drives "
        "the linkage; omega ~ sqrt(c1 (1/J_flywheel + 1/J_crank))"),
)
