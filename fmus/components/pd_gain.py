"""Gain FMU (test component): a pure direct feed-through y = k*u + offset, and the integral of u."""
from ..declaration import Component, Input, Output
from ..physics.testing import GainModel


class Gain(Component):
    model = GainModel
    description = ("Test component: y = clip(k*u + offset, -limit, limit) depends directly on u "
                   "(two Gains in a ring are an algebraic loop); integral is the time integral of u.")
    signals = (Input("u", "1", "input signal", start=0.0),
               Output("y", "1", "k*u + offset, saturated at +-limit"),
               Output("integral", "s", "time integral of u"))
    feedthrough = {"y": ("u",)}
