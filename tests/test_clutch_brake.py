"""The clutch-brake on the main shaft (fmus/physics/clutch_brake.py, ClutchBrakeShaft): against the closed form of
a braked inertia (../shared/reference/press-engineering-facts.md, "Stopping"), as a model and as an FMU in a stop
run until settled."""
import math

import numpy as np
import pytest

from fmus.physics.clutch_brake import ClutchBrakeShaftModel, ClutchBrakeShaftParams
from harness.model import Experiment, Instance, System
from harness.run import simulate_scenario
from harness.specs import Change, QuantitySpec, Scenario

J1, J2, W0, T_B, DELAY, LOAD = 8.0, 0.5, 6.0, 100.0, 0.03, 20.0     # kg.m2, kg.m2, rad/s, N.m, s, N.m


def _model(**kw):
    return ClutchBrakeShaftModel(ClutchBrakeShaftParams(J_flywheel=J1, J_crank=J2, w0=W0, cb_torque=T_B,
                                                        cb_delay=DELAY, d=0.06, l=0.8, **kw))


def test_the_crank_side_stops_as_a_braked_inertia_and_the_flywheel_runs_on():
    """Commanded at 0 with a load torque on the crank: the whole shaft decelerates by LOAD / (J1 + J2) for the
    delay (the shaft's twist oscillates about that), then the crank side alone by (T_b + LOAD) / J2 to rest,
    located inside the step; at rest the brake holds the load (its reaction); the flywheel keeps its speed."""
    m = _model()
    u = [0.0, -LOAD, 0.0, 1.0]
    x = m.initial_state(u)
    t, h = 0.0, 5e-4
    while x[3] != 0.0 and t < 1.0:
        x = m.advance(t, h, x, u)
        t += h
    w_open = x[1]                                   # the flywheel side's speed: unchanged since the clutch opened
    closed_w = W0 - LOAD / (J1 + J2) * DELAY        # the rigid-body speed at the opening
    assert w_open == pytest.approx(closed_w, rel=2e-3)
    # its stop: the crank's speed at the opening (the shaft's oscillation about the rigid motion is small) over the
    # deceleration
    assert t == pytest.approx(DELAY + closed_w / ((T_B + LOAD) / J2), abs=h + 1e-3)
    y = m.output(t, x, u)
    assert y[-1] == pytest.approx(LOAD) and y[6] == 0.0           # holding reaction; no shaft torque while open
    x2 = m.advance(t, 0.1, x, u)
    assert x2[3] == 0.0 and x2[2] == x[2] and x2[1] == pytest.approx(w_open)
    # released: the clutch closes with the twist it has as its zero, so no spring torque at once
    x3 = m.advance(t, 0.0, x2, [0.0, -LOAD, 0.0, 0.0])
    assert m.output(t, x3, [0.0, -LOAD, 0.0, 0.0])[7] == 0.0


def test_without_a_command_it_is_the_flywheel_shaft():
    from fmus.physics.flywheel_shaft import FlywheelShaftModel, FlywheelShaftParams

    m, plain = _model(), FlywheelShaftModel(FlywheelShaftParams(J_flywheel=J1, J_crank=J2, w0=W0, d=0.06, l=0.8))
    x, xp = m.initial_state([0, 0, 0, 0]), plain.initial_state([0, 0, 0])
    for k in range(50):
        u = [5.0 * math.sin(0.1 * k), -3.0, 1.0]
        x, xp = m.advance(k * 1e-3, 1e-3, x, u + [0.0]), plain.advance(k * 1e-3, 1e-3, xp, u)
    assert np.array_equal(x[:5], xp) and tuple(m.output(0.05, x, u + [0.0]))[:-1] == tuple(plain.output(0.05, xp, u))


def test_clutch_brake_fmu_stops_within_the_closed_form():
    """The FMU alone, no load: the crank side stops t_d + w / (T_b / J2) after the command, turning w t_d + w^2 /
    (2 T_b / J2) (to the 1 % band), its brake takes 1/2 J2 w^2; the flywheel runs on at w."""
    s = System(name="clutch_brake_alone", description="a clutch-brake shaft",
               instances=[Instance("flywheel", "ClutchBrakeShaft", {"J_flywheel": J1, "J_crank": J2, "w0": W0,
                                                                    "cb_torque": T_B, "cb_delay": DELAY})],
               bonds=[], experiment=Experiment(stop_time=0.3, step=1e-4, master="jacobi"),
               free_inputs={"flywheel.pulley.tau": "no belt", "flywheel.crank.tau": "no load",
                            "flywheel.aux.tau": "no load", "flywheel.clutch_brake": "the stop commands it"})
    s.quantities = QuantitySpec(shaft_angle="flywheel.crank.phi", shaft_speed="flywheel.crank.w", shaft_name="crank",
                                brakes=(("clutch_brake", "flywheel.clutch_brake_torque", "flywheel.crank.w",
                                         "the clutch-brake"),))
    stop = Scenario("estop", "stop", "stop", 0.2, (Change(0.05, "flywheel.clutch_brake", 1.0),))
    df = simulate_scenario(s, stop)
    q = df.attrs["transient"]
    a, b = T_B / J2, 0.01
    assert q["stopping_time"] == pytest.approx(DELAY + (1 - b) * W0 / a, rel=1e-3)
    assert q["stopping_angle"] == pytest.approx(math.degrees(W0 * DELAY + (1 - b * b) * W0 ** 2 / (2 * a)), rel=1e-3)
    # the brake energy is the trapezoidal integral of the sampled power: where the brake acts from mid-step, half a
    # step's T_b w h is missed or added, a share of about 2 a h / w = 0.7 % here (measured: 8.970 J against 9 J)
    assert q["brake_energy"] == pytest.approx(0.5 * J2 * W0 ** 2, rel=1e-2)
    assert df["flywheel.pulley.w"].iloc[-1] == pytest.approx(W0, rel=1e-9)
