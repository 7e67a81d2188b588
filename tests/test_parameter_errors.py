"""Bad parameters of every component model are named: one table of (model, parameters, what the one-line
ParameterError must say), each row a value outside what its equations admit.  The rows were the parameter-error
tests of the component files (test_cam_rocker, test_conveyor, test_differential, test_flywheel_shaft,
test_foundation_equations, test_fourbar, test_gear_sectors, test_knife, test_motor_belt, test_rack_bed), merged
here unchanged (issue 57); the same models through their FMUs: test_fmus_built, test_messages."""
from __future__ import annotations

import math

import pytest

from fmus.physics import conveyor as cv
from fmus.physics import gear_sectors as gs
from fmus.physics import knife as kn
from fmus.physics.base import ParameterError
from fmus.physics.cam_rocker import CamRockerModel, CamRockerParams
from fmus.physics.differential import JamesDifferentialModel, JamesDifferentialParams
from fmus.physics.elements import InertiaModel, InertiaParams
from fmus.physics.flywheel_shaft import FlywheelShaftModel, FlywheelShaftParams
from fmus.physics.fourbar import FourBarModel, FourBarParams
from fmus.physics.motor_belt import MotorBeltModel, MotorBeltParams
from fmus.physics.rack_bed import RackBedModel, RackBedParams

CASES = [  # (model, parameters class, the bad parameters, a regular expression the message must match)
    (CamRockerModel, CamRockerParams, dict(lambda2=3.0), "lambda2"),
    (CamRockerModel, CamRockerParams, dict(mechanism=1, phase_forward=4.0, phase_return=3.0), "phase_return"),
    (CamRockerModel, CamRockerParams, dict(mechanism=1, fidelity=3), "fidelity.*mechanism 0"),
    (cv.ConveyorLoadModel, cv.ConveyorLoadParams, dict(zone=1.3), "zone"),
    (cv.ConveyorLoadModel, cv.ConveyorLoadParams, dict(cut_length=0.5), "cut_length"),
    (JamesDifferentialModel, JamesDifferentialParams, dict(z_ring=70), "parameter z_ring = "),
    (JamesDifferentialModel, JamesDifferentialParams, dict(n_planets=5), "parameter n_planets = "),
    (JamesDifferentialModel, JamesDifferentialParams, dict(n_planets=6), "parameter n_planets = "),
    # 96/6 = 16 assembles, but 48 sin(30 deg) = 24 < 26: the planets' neighbourhood
    (JamesDifferentialModel, JamesDifferentialParams, dict(n_planets=6), "neighbourhood"),
    (JamesDifferentialModel, JamesDifferentialParams, dict(efficiency=1.2), "parameter efficiency = "),
    (FlywheelShaftModel, FlywheelShaftParams, dict(psi=13.0), "psi = 13.0"),
    (FlywheelShaftModel, FlywheelShaftParams, dict(d=0.0), "d = 0.0"),
    (InertiaModel, InertiaParams, dict(J=-0.5), r"parameter J = -0\.5 is not admissible: must be > 0 kg\.m2"),
    (InertiaModel, InertiaParams, dict(c_ground=-1.0), "c_ground"),
    (InertiaModel, InertiaParams, dict(J=float("nan")), "finite"),
    (FourBarModel, FourBarParams, dict(rocker_length=5.0), "rocker_length = 5"),
    (FourBarModel, FourBarParams, dict(crank_length=0.3), "crank_length"),
    (FourBarModel, FourBarParams, dict(friction_ratio=1.0), "friction_ratio"),
    (gs.GearSectorsModel, gs.GearSectorsParams, dict(phi3=0.5), "parameter phi3 = 0.5"),
    (gs.GearSectorsModel, gs.GearSectorsParams, dict(J_cyl=-1.0), "parameter J_cyl = -1"),
    (gs.GearSectorsModel, gs.GearSectorsParams, dict(v1=5.0), "no feasible sector synthesis"),
    (kn.KnifeLoadModel, kn.KnifeLoadParams, dict(T_cut=0.0), "parameter T_cut = 0"),
    (kn.KnifeLoadModel, kn.KnifeLoadParams, dict(phi_s=math.pi), "parameter phi_s"),
    (MotorBeltModel, MotorBeltParams, dict(w_rated=200.0, w_sync=157.0), "w_rated"),
    (MotorBeltModel, MotorBeltParams, dict(breakdown_ratio=1.0), "breakdown_ratio = 1.0"),
    (RackBedModel, RackBedParams, dict(s_print_start=0.5, s_print_end=0.52, ramp=0.02), "s_print_end"),
    (RackBedModel, RackBedParams, dict(m_T=-1.0), "m_T = -1.0"),
]


@pytest.mark.parametrize("model, params, bad, message", CASES,
                         ids=[f"{m.__name__}-{'-'.join(b)}-{k}" for k, (m, _, b, _) in enumerate(CASES)])
def test_a_bad_parameter_is_named(model, params, bad, message):
    with pytest.raises(ParameterError, match=message) as info:
        model(params(**bad))
    assert "\n" not in str(info.value)
