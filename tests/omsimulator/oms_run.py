"""Runs one FMU or design file in OMSimulator and prints what it read: the opt-in importer tests' driver.

OMSimulator lives in its own environment (see tests/test_importers.py), so the tests run this file with that
environment's Python: `python oms_run.py REQUEST.json`. The request says what to run:

    {"entry": "fmu", "fmu": PATH, "system": "wc" | "sc", "stop_time": 8.0, "integers": {name: value},
     "reals": {name: value}, "tolerance": 1e-9 | null, "outputs": [name, ...]}
    {"entry": "import_file" | "ssp_class", "ssp": PATH, "system": NAME, "component": NAME, "outputs": [name, ...]}
    {"entry": "system", "ssp": PATH, "system": NAME, "stop_time": 0.4, "outputs": ["component.name", ...]}

"wc" is OMSimulator's weakly coupled system (Co-Simulation, oms-ma), "sc" its strongly coupled one (Model
Exchange with CVODE, at OMSimulator's defaults unless "tolerance" is given). "system" imports a system of several
FMUs (the armour system) through oms_importFile with its own master and step, run to "stop_time" when given
(else the file's), and reads outputs of any of its components. One line printed is
`RESULT {json}` with the outputs read after the run and every status that was not ok; OMSimulator's own log
(its `error:` lines) goes to stdout around it. Nothing here imports the project: it runs with only
OMSimulator installed.
"""

import ctypes
import json
import sys
import tempfile

from OMSimulator import CRef, Capi, SSP

SYSTEM_TYPES = {"wc": 1, "sc": 2}


def check(failures, what, status):
    if status.name != "ok":
        failures.append(f"{what}: {status.name}")


def read(failures, cref):
    value, status = Capi.getReal(cref)
    check(failures, f"getReal {cref}", status)
    return value


def run_fmu(request, failures):
    check(failures, "newModel", Capi.newModel("m"))
    check(failures, "addSystem", Capi.addSystem("m.root", SYSTEM_TYPES[request["system"]]))
    check(failures, "addSubModel", Capi.addSubModel("m.root.lattice", request["fmu"]))
    if request.get("tolerance") is not None:
        check(failures, "setTolerance", Capi.setTolerance("m.root", float(request["tolerance"])))
    Capi.setResultFile("m", "", 0)
    Capi.setStopTime("m", float(request["stop_time"]))
    for name, value in request.get("integers", {}).items():
        check(failures, f"setInteger {name}", Capi.setInteger(f"m.root.lattice.{name}", int(value)))
    for name, value in request.get("reals", {}).items():
        check(failures, f"setReal {name}", Capi.setReal(f"m.root.lattice.{name}", float(value)))
    for step in ("instantiate", "initialize", "simulate"):
        check(failures, step, getattr(Capi, step)("m"))
    values = {name: read(failures, f"m.root.lattice.{name}") for name in request["outputs"]}
    Capi.terminate("m")
    Capi.delete("m")
    return values


def import_and_run(request, failures, outputs):
    """oms_importFile, then instantiate, initialize and simulate; the values of `outputs` (cref -> name)."""
    Capi.obj.oms_importFile.argtypes = [ctypes.c_char_p, ctypes.POINTER(ctypes.c_char_p)]
    Capi.obj.oms_importFile.restype = ctypes.c_int
    name = ctypes.c_char_p()
    status = Capi.obj.oms_importFile(request["ssp"].encode(), ctypes.byref(name))
    if status != 0:
        failures.append(f"oms_importFile: status {status}")
        return {}
    model = name.value.decode()
    Capi.setResultFile(model, "", 0)
    if request.get("stop_time") is not None:
        check(failures, "setStopTime", Capi.setStopTime(model, float(request["stop_time"])))
    for step in ("instantiate", "initialize", "simulate"):
        check(failures, step, getattr(Capi, step)(model))
    values = {output: read(failures, f"{model}.{request['system']}.{cref}") for cref, output in outputs.items()}
    Capi.terminate(model)
    Capi.delete(model)
    return values


def run_import_file(request, failures):
    return import_and_run(request, failures, {f"{request['component']}.{o}": o for o in request["outputs"]})


def run_system(request, failures):
    return import_and_run(request, failures, {output: output for output in request["outputs"]})


def run_ssp_class(request, failures):
    model = SSP(request["ssp"], temp_dir=request["temp_dir"])
    instance = model.instantiate()
    instance.setResultFile("", 0)
    instance.initialize()
    instance.simulate()
    values = {
        output: instance.getValue(CRef(request["system"], request["component"], output))
        for output in request["outputs"]
    }
    instance.terminate()
    instance.delete()
    return values


def main(path):
    with open(path) as handle:
        request = json.load(handle)
    Capi.setTempDirectory(tempfile.mkdtemp(dir=request["temp_dir"]))
    failures = []
    runners = {"fmu": run_fmu, "import_file": run_import_file, "ssp_class": run_ssp_class, "system": run_system}
    runner = runners[request["entry"]]
    values = runner(request, failures)
    print("RESULT " + json.dumps({"values": values, "failures": failures}), flush=True)


if __name__ == "__main__":
    main(sys.argv[1])
