"""What a run would cost if part of it were free: stand-ins for the FMUs' work, for the real-time floors of
:mod:`benchmarks.bench`.

A floor run is the declared model's run as the benchmark times it, except that right after initialisation
(``fmi2ExitInitializationMode``) every FMU on the in-process path gets stand-ins:

* ``"physics"``: each model's ``advance`` returns its state unchanged and its ``output`` the values it
  computed at the end of initialisation.  What is left is the master and, around each model, the FMU's own
  layer (:class:`fmus.slave.PressSlave`: input checks, state copies, output refresh, value references) and
  the in-process calls (:mod:`harness.fmi.inprocess`): the least a run of these FMUs can cost with this
  master, however fast their equations are.
* ``"fmu-calls"``: every ``fmi2DoStep`` succeeds at once, ``fmi2SetReal`` does nothing and ``fmi2GetReal``
  returns the values read at the end of initialisation.  What is left is the master alone.

The results of a floor run are meaningless (constant outputs) and are thrown away; only its wall time counts.
A stand-in's own calls cost a little, so a floor is slightly above the true one.
"""
from __future__ import annotations

import contextlib

STAND_INS = ("physics", "fmu-calls")


def _physics_free(fmu) -> None:
    slave = fmu._slave
    model = slave._model
    frozen = tuple(model.output(slave._time, slave._x, slave._u))
    model.advance = lambda t0, h, x, u: x
    model.output = lambda t, x, u: frozen


def _calls_free(fmu) -> None:
    real_get, cache = fmu._get_real, {}

    def get(refs):
        values = cache.get(id(refs))
        if values is None:
            values = cache[id(refs)] = (refs, real_get(refs))  # keeps refs alive: its id stays its own
        return list(values[1])

    fmu._get_real = get
    fmu._set_real = lambda refs, values: None
    fmu._step = lambda t, h: True


@contextlib.contextmanager
def stand_ins(kind: str | None):
    """Within the block, every in-process FMU initialised gets the stand-ins ``kind`` (module docstring); None:
    none (a real run).  Yields the list of the instances patched so far (a caller checks that none is missing:
    an FMU called through its C library gets no stand-in)."""
    patched_names: list[str] = []
    if kind is None:
        yield patched_names
        return
    if kind not in STAND_INS:
        raise ValueError(f"stand-in kind {kind!r} is not admissible: must be one of {', '.join(STAND_INS)}")
    from harness.fmi.inprocess import InProcessFMU

    exit_initialization = InProcessFMU.exit_initialization
    patch = _physics_free if kind == "physics" else _calls_free

    def patched(self):
        exit_initialization(self)
        patch(self)
        patched_names.append(self.name)

    InProcessFMU.exit_initialization = patched
    try:
        yield patched_names
    finally:
        InProcessFMU.exit_initialization = exit_initialization
