"""A plain pythonfmu slave for tests/test_interrupt.py: a sweep point that cannot end before the test lets it.
With ``k`` < 0 each step waits while the file named by the environment variable PRESSDRIVE_TEST_GATE exists
(looking every 20 ms; a Ctrl-C stops it there); ``y`` = k t.  Built with ``pythonfmu build``."""
import os
import time

from pythonfmu import Fmi2Causality, Fmi2Slave, Fmi2Variability, Real


class PlainGate(Fmi2Slave):
    author = "pressdrive tests"
    description = "waits at a gate file"

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        self.k = 1.0
        self.y = 0.0
        self.register_variable(Real("y", causality=Fmi2Causality.output))
        self.register_variable(Real("k", causality=Fmi2Causality.parameter, variability=Fmi2Variability.tunable))

    def do_step(self, current_time, step_size):
        gate = os.environ.get("PRESSDRIVE_TEST_GATE", "")
        while self.k < 0 and gate and os.path.exists(gate):
            time.sleep(0.02)
        self.y = self.k * (current_time + step_size)
        return True
