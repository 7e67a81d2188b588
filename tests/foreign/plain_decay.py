"""A plain pythonfmu slave without outputs, as people write a first model: x' = -x / tau by explicit Euler,
the state a ``local`` variable (and ``Quiet``, with no variable to record at all).  Built by
tests/test_foreign.py with ``pythonfmu build``."""
from pythonfmu import Fmi2Causality, Fmi2Slave, Fmi2Variability, Real


class PlainDecay(Fmi2Slave):
    author = "pressdrive tests"
    description = "exponential decay of a local state, no outputs"

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        self.x = 1.0
        self.tau = 0.5
        self.register_variable(Real("x", causality=Fmi2Causality.local, variability=Fmi2Variability.continuous))
        self.register_variable(Real("tau", causality=Fmi2Causality.parameter, variability=Fmi2Variability.tunable))

    def do_step(self, current_time, step_size):
        self.x -= step_size * self.x / self.tau
        return True
