"""A plain pythonfmu slave with Integer and Boolean outputs (no dependencies, no FMU state), built by
tests/test_foreign.py with ``pythonfmu build``: counts its steps (Integer ``n`` = steps // ``every``) and
says whether ``n`` is odd (Boolean ``odd``)."""
from pythonfmu import Boolean, Fmi2Causality, Fmi2Slave, Fmi2Variability, Integer


class Stairs(Fmi2Slave):
    author = "pressdrive tests"
    description = "integer staircase"

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        self.n = 0
        self.odd = False
        self.every = 1
        self.register_variable(Integer("n", causality=Fmi2Causality.output,
                                       variability=Fmi2Variability.discrete))
        self.register_variable(Boolean("odd", causality=Fmi2Causality.output,
                                       variability=Fmi2Variability.discrete))
        self.register_variable(Integer("every", causality=Fmi2Causality.parameter,
                                       variability=Fmi2Variability.tunable))
        self._count = 0

    def do_step(self, current_time, step_size):
        self._count += 1
        self.n = self._count // self.every
        self.odd = self.n % 2 == 1
        return True
