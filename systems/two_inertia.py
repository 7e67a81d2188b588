"""Two inertias coupled by a spring-damper across the FMU boundary (force-displacement coupling).

The classic co-simulation benchmark: ``a`` (Inertia, motion out) drives ``b`` (SpringInertia, motion in,
feed-through torque).  Its one-step map is known in closed form (harness.studies.stability), so it measures
convergence orders and stability limits of the masters.  Undamped and free-free by default: the coupled
system conserves energy, so any energy change is made by the coupling.
"""
from harness.model import Experiment, Instance, System, bond
from harness.specs import PrecisionSpec, Scene

SYSTEM = System(
    name="two_inertia",
    description="Two inertias coupled by a spring-damper across the FMU boundary (co-simulation benchmark)",
    instances=[
        Instance("a", "Inertia", {"J": 0.01, "w0": 1.0}),            # J [kg.m2], w0 [rad/s]
        Instance("b", "SpringInertia", {"J": 0.02, "c": 100.0, "d": 0.0}),  # J [kg.m2], c [N.m/rad], d [N.m.s/rad]
    ],
    bonds=[bond("a.flange", "b.drive")],
    # The interface-Jacobian master (harness.master.jacobian): stable at any step here, second order where the step
    # resolves the spring; Jacobi with zero-order hold, the textbook setup, grows at every step
    # (`--master jacobi --extrapolation 0`: stopped as diverged at 0.7 s)
    experiment=Experiment(stop_time=1.0, step=1e-3, master="jacobian", extrapolation=1),
    scenes=[  # no component has fidelity levels: the scenes differ in the step and master they need
        Scene("mean_speed", "At what mean speed does the pair turn (momentum)?",
              'mean(window(r["a.flange.w"], 0.0, 0.2))', tolerance=0.05, unit="rad/s", stop_time=0.2, step=2.5e-5),
        Scene("peak_torque", "What peak torque does the coupling spring carry?",
              'peak(window(r["b.drive.tau"], 0.0, 0.2))', tolerance=0.01, unit="N.m", stop_time=0.2, step=2.5e-5),
    ],
    default_scene="peak_torque",  # the coupling benchmark's quantity: the spring torque across the FMU boundary
    precision=PrecisionSpec("b.drive.tau", "coupling torque", "N.m", stop_time=0.5,
                            steps=(2.5e-4, 5e-4, 1e-3, 2e-3), columns=("a.flange.w",)),
)
