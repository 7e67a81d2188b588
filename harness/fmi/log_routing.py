"""The process-wide FMI 2.0 logger: FMPy's native proxy formats each variadic message and this module routes
it to the instance that logged it (by instance name), whichever copy of the harness package installed the proxy."""
from __future__ import annotations

import sys
import types
from ctypes import byref

from fmpy.fmi1 import calloc, free
from fmpy.fmi2 import (fmi2CallbackAllocateMemoryTYPE, fmi2CallbackFreeMemoryTYPE, fmi2CallbackFunctions,
                       fmi2CallbackLoggerTYPE)

from harness.fmi.status import _LABELS

# -- log capture ------------------------------------------------------------------------------------------------
# One logger for every instance (fmpy's native proxy formats the variadic message first); messages are routed
# to the wrapper by instance name.  fmpy's proxy holds ONE Python logger for the whole process, and a drive FMU
# loaded in this process brings its own copy of this module (harness.export.drive_fmu), which installs its logger: so
# the routing table is one for the process (a fixed entry in sys.modules), and whichever copy's logger the proxy
# holds finds every copy's instances.
_ROUTES = sys.modules.setdefault("_pressdrive_fmi_log_routes",
                                 types.ModuleType("_pressdrive_fmi_log_routes", "FMI log routing (harness.fmi.fmu)"))
if not hasattr(_ROUTES, "by_name"):
    _ROUTES.by_name = {}
_BY_NAME: dict[bytes, object] = _ROUTES.by_name  # instance name -> its FMI 2.0 wrapper (harness.fmi.fmu.FMU)


def _log(env, instance_name, status, category, message):
    fmu = _BY_NAME.get(instance_name)
    text = message.decode("utf-8", "replace") if message else ""
    if fmu is None:  # fmpy's native proxy keeps ONE Python logger for all FMUs: behave like fmpy's for others
        print(f"[{_LABELS[status].upper() if 0 <= status < 6 else status}] {text}")
        return
    fmu._logged(status, category.decode("utf-8", "replace") if category else "", text)


_CALLBACKS = fmi2CallbackFunctions()
_LOGGER = fmi2CallbackLoggerTYPE(_log)
_CALLBACKS.logger = _LOGGER
_CALLBACKS.allocateMemory = fmi2CallbackAllocateMemoryTYPE(calloc)
_CALLBACKS.freeMemory = fmi2CallbackFreeMemoryTYPE(free)


def _install_proxy() -> None:
    """fmpy's native proxy formats variadic messages; it holds a single Python logger for the process, so it
    is (re)installed before each instantiation (unknown instances are printed as fmpy does)."""
    try:
        from fmpy.logging import addLoggerProxy

        _CALLBACKS.logger = _LOGGER   # the proxy takes the logger it finds here (not itself, once installed)
        addLoggerProxy(byref(_CALLBACKS))
    except Exception:  # pragma: no cover - no native proxy: messages arrive unformatted
        pass


_install_proxy()
