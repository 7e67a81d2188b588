"""A plain pythonfmu slave with Integer, Boolean and String variables (no dependencies, no FMU state),
built by tests/test_foreign.py with ``pythonfmu build``: sums ``n + odd*bonus`` each step into Real ``y``
and echoes ``n`` as ``n_seen``."""
from pythonfmu import Boolean, Fmi2Causality, Fmi2Slave, Fmi2Variability, Integer, Real, String


class Tally(Fmi2Slave):
    author = "pressdrive tests"
    description = "sums integer and boolean inputs"

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        self.n = 0
        self.odd = False
        self.bonus = 10.0
        self.label = "tally"
        self.y = 0.0
        self.n_seen = 0
        self.register_variable(Integer("n", causality=Fmi2Causality.input,
                                       variability=Fmi2Variability.discrete))
        self.register_variable(Boolean("odd", causality=Fmi2Causality.input,
                                       variability=Fmi2Variability.discrete))
        self.register_variable(Real("bonus", causality=Fmi2Causality.parameter, variability=Fmi2Variability.tunable))
        self.register_variable(String("label", causality=Fmi2Causality.parameter,
                                      variability=Fmi2Variability.tunable))
        self.register_variable(Real("y", causality=Fmi2Causality.output))
        self.register_variable(Integer("n_seen", causality=Fmi2Causality.output,
                                       variability=Fmi2Variability.discrete))

    def do_step(self, current_time, step_size):
        self.y += self.n + (self.bonus if self.odd else 0.0)
        self.n_seen = self.n
        return True
