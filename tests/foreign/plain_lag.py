"""A plain pythonfmu slave, written the way a new user writes one: a first-order lag
y' = (k*u - y)/tau by explicit Euler inside the step.  No ModelStructure dependencies (pythonfmu writes
none), no FMU-state support (pythonfmu's default).  Built by tests/test_foreign.py with ``pythonfmu build``."""
from pythonfmu import Fmi2Causality, Fmi2Slave, Fmi2Variability, Real


class PlainLag(Fmi2Slave):
    author = "pressdrive tests"
    description = "first-order lag, plain pythonfmu"

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        self.u = 0.0
        self.y = 0.0
        self.k = -0.5
        self.tau = 1.0
        self.y0 = 0.0
        self.register_variable(Real("u", causality=Fmi2Causality.input))
        self.register_variable(Real("y", causality=Fmi2Causality.output))
        for name in ("k", "tau", "y0"):
            self.register_variable(Real(name, causality=Fmi2Causality.parameter,
                                        variability=Fmi2Variability.tunable))

    def exit_initialization_mode(self):
        self.y = self.y0

    def do_step(self, current_time, step_size):
        self.y += step_size * (self.k * self.u - self.y) / self.tau
        return True
