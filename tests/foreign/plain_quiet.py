"""A plain pythonfmu slave with nothing to record: one parameter, no outputs, no local variables.  Built by
tests/test_foreign.py with ``pythonfmu build``."""
from pythonfmu import Fmi2Causality, Fmi2Slave, Fmi2Variability, Real


class PlainQuiet(Fmi2Slave):
    author = "pressdrive tests"
    description = "a parameter and nothing else"

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        self.gain = 2.0
        self.register_variable(Real("gain", causality=Fmi2Causality.parameter, variability=Fmi2Variability.tunable))

    def do_step(self, current_time, step_size):
        return True
