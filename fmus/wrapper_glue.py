"""What the C side of an FMU needs from its Python slave, beside the slave's behaviour (:mod:`fmus.slave_core`).

* :func:`hold_module_dict`: a workaround for a reference-count bug of the pythonfmu 0.7 C wrapper;
* the loader bridge (:data:`LOADER_BRIDGE`, :func:`offer_to_loader`): how a slave hands its directional
  derivatives to the host loader ``fmus/loader/pressdrive_loader.c``, which pythonfmu's wrappers give no way to
  reach the slave object.

Part of every FMU's code (``fmus/build.py``: ``RUNTIME``); standard library only.
"""
from __future__ import annotations

import sys
import threading
import types
import weakref

_MODULE_DICT_REFS: list = []


def hold_module_dict(cls: type) -> None:
    """Work around a reference-count bug of the pythonfmu 0.7 C wrapper.

    On every ``fmi2Instantiate`` its ``findClass`` re-executes the FMU's module source (with the module's
    ``__dict__`` as globals) and then releases that *borrowed* ``__dict__`` once.  A component module that
    defines no functions holds its dict only through the module object, so the first instantiation frees
    it and the second crashes.  Every class statement that derives from the base slave runs this hook
    (``PressBehaviour.__init_subclass__``), on import and again on each re-execution by the wrapper, so each
    release is matched by one reference taken just before it (tests/test_fmus_built.py::
    test_many_instances_in_one_process).  Module dicts live as long as the process anyway, so the extra
    references cost nothing elsewhere.
    """
    module = sys.modules.get(cls.__module__)
    if module is not None:
        _MODULE_DICT_REFS.append(vars(module))


# The module through which a slave offers its directional derivatives to the host loader
# (fmus/loader/pressdrive_loader.c): pythonfmu's wrappers answer fmi2/fmi3GetDirectionalDerivative "not supported"
# and give the loader no way to reach the slave object, so each slave, while the wrapper constructs it inside
# fmi*Instantiate, leaves its ``directional_derivative`` here under the constructing thread's id; the loader, on
# the same thread right after the wrapper returns the instance, takes it (``take()``) and keeps it by instance.
# A fixed name in ``sys.modules``, not a module of this package: every FMU packs its own copy of this package
# under its own name, and one loader serves them all.
LOADER_BRIDGE = "_pressdrive_directional_derivatives"


def offer_to_loader(instance_name: str, directional_derivative) -> None:
    """Offer a slave's bound method (weakly: a slave made outside the loader, in process, is not kept alive by an
    offer nobody takes; the next construction on the thread replaces it)."""
    bridge = sys.modules.get(LOADER_BRIDGE)
    if bridge is None:
        bridge = types.ModuleType(LOADER_BRIDGE, "directional derivatives offered to the host loader "
                                                 "(fmus.wrapper_glue)")
        bridge.offered = {}
        bridge.take = _take_offer
        sys.modules[LOADER_BRIDGE] = bridge
    bridge.offered[threading.get_ident()] = (instance_name, weakref.WeakMethod(directional_derivative))


def _take_offer():
    """(instance name, directional_derivative) offered on this thread, removed from the bridge, or None."""
    entry = sys.modules[LOADER_BRIDGE].offered.pop(threading.get_ident(), None)
    method = entry[1]() if entry is not None else None
    return None if method is None else (entry[0], method)
