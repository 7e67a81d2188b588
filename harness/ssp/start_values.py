"""The start values an SSP export binds, in two forms:

* :func:`consistent_inputs`: the connected inputs' consistent start values of a system, computed by
  initializing it with its master (bound in the .ssd as the inputs' start values,
  :func:`harness.ssp.export.export_ssp`);
* :func:`copy_with_start_values`: per-instance FMU copies whose own start values are the instance's values.

An SSP binds each component's parameter values (and the connected inputs' consistent start values) in its
.ssd; libcosim, Ecos, OMSimulator and the harness apply them.  FMPy's ``simulate_ssp`` applies none unless the
caller passes a ``parameter_set``: its FMUs run on their defaults (the exported bed drive: the crank at
-1.75e4 rad/s by 1 ms).  So the export packs, for every instance of a toolkit FMU (FMI 2.0) with values, a copy
of the FMU that starts from them by itself:

* ``modelDescription.xml``: the values as the variables' ``start`` attributes (what an importer reads), the
  slave class named in the toolkit's annotation and ``resources/slavemodule.txt`` pointing at
* ``resources/<module>__<tag>.py``: a subclass of the FMU's slave class that, when instantiated, sets those
  values on itself through its own ``set_real``/``set_integer`` (as a host would before initialisation).

pythonfmu's wrapper takes the most derived slave class of the module ``slavemodule.txt`` names: the subclass.
The copy's code (the ``fmus_<hash>`` package, the declaration) is the original's; only its module name is its own
(``__<tag>``: the instance name and a digest of the values), so copies of one FMU load side by side.
"""
from __future__ import annotations

import hashlib
import io
import re
import zipfile
from pathlib import Path
from xml.etree import ElementTree as ET

from harness.model import System, model_description, resolve_fmu

_KINDS = {"Real": float, "Integer": int, "Enumeration": int}


def copy_with_start_values(fmu: Path, instance: str, values: dict) -> bytes | None:
    """The bytes of a copy of ``fmu`` whose start values are ``values`` (``{variable: value}``), or None when the
    FMU is not a toolkit FMI 2.0 FMU (its annotation names no slave class) or no value is Real or Integer."""
    with zipfile.ZipFile(fmu) as z:
        infos = z.infolist()
        files = {i.filename: z.read(i.filename) for i in infos}
    root = ET.fromstring(files["modelDescription.xml"])
    if root.get("fmiVersion") != "2.0":
        return None
    slave = root.find("VendorAnnotations/Tool[@name='org.pressdrive']/Slave")
    if slave is None or "resources/slavemodule.txt" not in files:
        return None
    reals, ints = {}, {}
    for sv in root.find("ModelVariables"):
        name = sv.get("name")
        if name not in values or sv.get("causality") not in ("parameter", "input"):
            continue
        for kind, cast in _KINDS.items():
            el = sv.find(kind)
            if el is not None:
                value = cast(values[name])
                el.set("start", repr(value) if cast is float else str(value))
                (reals if cast is float else ints)[int(sv.get("valueReference"))] = value
    if not reals and not ints:
        return None
    module, cls = slave.get("module"), slave.get("class")
    digest = hashlib.sha1(repr((sorted(reals.items()), sorted(ints.items()))).encode()).hexdigest()[:8]
    tag = f"{re.sub(r'[^0-9A-Za-z_]', '_', instance)}_{digest}"
    new_module, new_cls = f"{module}__{tag}", f"{cls}__{tag}"
    slave.set("module", new_module)
    slave.set("class", new_cls)
    files["resources/slavemodule.txt"] = (new_module + "\n").encode()
    files[f"resources/{new_module}.py"] = (
        f'"""{cls} of instance {instance}: its values as its own start values (harness.ssp.start_values)."""\n'
        f"from {module} import {cls} as _Slave\n\n"
        f"REALS = {reals!r}\nINTEGERS = {ints!r}\n\n\n"
        f"class {new_cls}(_Slave):\n"
        f"    def __init__(self, **kwargs):\n"
        f"        super().__init__(**kwargs)\n"
        f"        if REALS:\n"
        f"            self.set_real(list(REALS), list(REALS.values()))\n"
        f"        if INTEGERS:\n"
        f"            self.set_integer(list(INTEGERS), list(INTEGERS.values()))\n").encode()
    files["modelDescription.xml"] = ET.tostring(root, encoding="utf-8", xml_declaration=True)
    out = io.BytesIO()
    with zipfile.ZipFile(out, "w", zipfile.ZIP_DEFLATED) as z:
        for name, data in files.items():
            z.writestr(name, data)
    return out.getvalue()


def consistent_inputs(system: System) -> dict[str, dict]:
    """Instance -> {input: value} of every connected input at the start of the default experiment, as the
    harness initialises the system (:meth:`harness.master.Master.initialize`: the outputs in initialization
    mode, each input from its source through the connection's transformation).

    The export binds them as the inputs' start values, because a host need not set inputs before
    initialization: FMPy's ``simulate_ssp`` sets none (only a parameter set), and an FMU that takes a state
    from an input (a motor's rotor angle from its pulley's, a four-bar's rocker from its crank) then starts
    from the input's FMU default, 0, and the exported bed drive in FMPy would start with its bed far off
    (tests/test_host_accuracy.py runs it in FMPy from these start values)."""
    from harness.master.clock import NS as NS_PER_S
    from harness.fmi import open_instance, release
    from harness.master import master_class

    paths = {inst.name: resolve_fmu(inst.fmu) for inst in system.instances}
    mds = {name: model_description(p) for name, p in paths.items()}
    exp = system.experiment
    start = float(exp.start_time) if exp is not None else 0.0
    fmus: dict = {}
    m = None
    try:
        for inst in system.instances:
            fmus[inst.name] = open_instance(paths[inst.name], inst.name, logging_on=False)
        m = master_class(exp.master if exp is not None else "jacobi")(fmus, system.all_connections(mds),
                                                                      system.bonds)
        m.initialize(int(round(start * NS_PER_S)), None, None, {i.name: dict(i.parameters) for i in system.instances})
        out: dict[str, dict] = {}
        for c in system.all_connections(mds):
            inst, var = c.target.split(".", 1)
            out.setdefault(inst, {})[var] = fmus[inst].get_value(var)
        return out
    finally:
        release(m, fmus)
