"""The FMI calls the FMU refuses, written from one table (fmu_src/common/refused_calls.h, a row each).

The built Linux libraries export exactly the functions the FMI headers declare (`nm -D`), and every row of the
table answers as its kind says, read from the table itself through the C preprocessor: REFUSED always fails with
its reason logged under the function's name; REFUSED_UNLESS_EMPTY and NO_VARIABLES_OF_TYPE fail for a call that
names a variable and return OK for one that names none.
"""

from __future__ import annotations

import ctypes
import re
import shutil
import subprocess
import zipfile
from dataclasses import dataclass
from pathlib import Path

import pytest
from fmpy import extract, read_model_description
from fmpy.fmi2 import FMU2Slave
from fmpy.fmi3 import FMU3Slave, fmi3LogMessageCallback

from builder.sources import FMU_SOURCE_DIR
from orchestrator.simulation import _CALLBACKS, _MESSAGES

OK, ERROR = 0, 3  # fmi2Status and fmi3Status alike
HEADERS = {2: "fmi2Functions.h", 3: "fmi3Functions.h"}
LIBRARY_FOLDERS = {2: "binaries/linux64/", 3: "binaries/x86_64-linux/"}
DECLARED = re.compile(r"FMI[23]_Export\s+\w+TYPE\s+(fmi[23]\w+)\s*;")
KINDS = ("REFUSED", "REFUSED_UNLESS_EMPTY", "NO_VARIABLES_OF_TYPE")


def declared_functions(version: int) -> set[str]:
    text = (FMU_SOURCE_DIR / "include" / HEADERS[version]).read_text()
    return set(DECLARED.findall(text))


def exported_functions(fmu: Path, version: int, folder: Path) -> set[str]:
    """The FMI functions the FMU's Linux library exports (its dynamic symbol table)."""
    nm = shutil.which("nm")
    if nm is None:
        pytest.skip("nm is not installed: apt-get install binutils")
    with zipfile.ZipFile(fmu) as archive:
        (member,) = [name for name in archive.namelist() if name.startswith(LIBRARY_FOLDERS[version])]
        library = archive.extract(member, folder)
    table = subprocess.run([nm, "-D", "--defined-only", library], capture_output=True, text=True, check=True).stdout
    return {line.split()[-1] for line in table.splitlines() if line.split()[-1].startswith(f"fmi{version}")}


@pytest.mark.parametrize("version", [2, 3])
def test_the_library_exports_every_function_the_fmi_header_declares(version, fmu_path, fmu3_path, tmp_path):
    declared = declared_functions(version)
    assert len(declared) > 40  # the header read, not an empty match
    assert exported_functions(fmu_path if version == 2 else fmu3_path, version, tmp_path) == declared


@dataclass(frozen=True)
class Row:
    """One refused call as the table declares it, its macros expanded."""

    kind: str
    function: str
    parameters: tuple[str, ...]  # as the C source declares each, e.g. "const fmi3ValueReference vr[]"
    reason: str


def table_rows(version: int) -> list[Row]:
    """The rows of FMI<version>_REFUSED_CALLS, expanded by the C preprocessor as the glue expands them."""
    compiler = shutil.which("gcc") or shutil.which("cc")
    if compiler is None:
        pytest.skip("no C compiler to read the table with")
    markers = "\n".join(f"#define {kind}(f, p, n, r) @ROW {kind} f p r @END" for kind in KINDS)
    source = f'#include "refused_calls.h"\n{markers}\nFMI{version}_REFUSED_CALLS\n'
    expanded = subprocess.run(
        [compiler, "-E", "-P", "-I", str(FMU_SOURCE_DIR / "common"), "-"],
        input=source,
        capture_output=True,
        text=True,
        check=True,
    ).stdout
    rows = []
    for text in re.findall(r"@ROW (.*?) @END", " ".join(expanded.split())):
        kind, function, rest = text.split(" ", 2)
        parameters, reason = re.fullmatch(r"\((.*)\) (\".*)", rest).groups()
        message = "".join(re.findall(r'"((?:[^"\\]|\\.)*)"', reason))  # adjacent literals, joined as C joins them
        if kind == "NO_VARIABLES_OF_TYPE":
            message = f"this FMU has no {message} variables"
        rows.append(Row(kind, function, tuple(p.strip() for p in parameters.split(",")), message))
    return rows


def argument_type(parameter: str):
    """The ctypes type a parameter is passed as: its C type, without its name."""
    declaration = parameter.replace("const ", "")
    c_type = declaration.split()[0]
    if declaration.endswith("[]") or "*" in declaration or c_type in ("fmi2Component", "fmi3Instance"):
        return ctypes.c_void_p
    scalar = {"size_t": ctypes.c_size_t, "fmi3Float64": ctypes.c_double, "fmi2Real": ctypes.c_double}
    if c_type in scalar:
        return scalar[c_type]
    if c_type in ("fmi2ValueReference", "fmi3ValueReference"):
        return ctypes.c_uint32
    if c_type in ("fmi2StatusKind",):
        return ctypes.c_int
    raise AssertionError(f"a parameter of a type this test does not pass: {parameter}")


def call(library, row: Row, instance, named_variables: int) -> int:
    """Calls the row's function on `instance` with `named_variables` value references (nvr), the rest zeros."""
    types = [argument_type(parameter) for parameter in row.parameters]
    prototype = ctypes.CFUNCTYPE(ctypes.c_int, *types)
    function = prototype(ctypes.cast(getattr(library, row.function), ctypes.c_void_p).value)
    references = (ctypes.c_uint32 * 1)(1)
    buffer = (ctypes.c_double * 8)()  # room for any value a refused call could write (none does)
    arguments = [instance]
    for parameter, kind in zip(row.parameters[1:], types[1:]):
        name = parameter.split()[-1].rstrip("[]").lstrip("*")
        if name == "nvr":
            arguments.append(named_variables)
        elif name == "vr":
            arguments.append(ctypes.cast(references, ctypes.c_void_p))
        elif kind is ctypes.c_void_p:
            arguments.append(ctypes.cast(buffer, ctypes.c_void_p))
        else:
            arguments.append(kind(0))
    return function(*arguments)


def test_the_table_holds_a_row_for_each_refused_call_of_both_versions():
    rows = {version: table_rows(version) for version in (2, 3)}
    for version, table in rows.items():
        functions = [row.function for row in table]
        assert len(functions) == len(set(functions)) and set(functions) <= declared_functions(version)
        instance_type = "fmi2Component" if version == 2 else "fmi3Instance"
        assert all(row.parameters[0].split()[0] == instance_type for row in table)
    assert {"fmi2CancelStep", "fmi2GetDirectionalDerivative"} <= {row.function for row in rows[2]}
    assert {"fmi3GetClock", "fmi3GetFloat32", "fmi3SetBinary"} <= {row.function for row in rows[3]}


def check_rows(library, instance, rows: list[Row], messages: list[str]) -> None:
    for row in rows:
        del messages[:]
        assert call(library, row, instance, 1) == ERROR, row.function
        assert messages == [f"{row.function}: {row.reason}"], (row.function, messages)
        if row.kind != "REFUSED":  # an empty call is fine
            assert call(library, row, instance, 0) == OK, row.function


def test_every_fmi3_refusal_answers_as_its_row_says(fmu3_path, tmp_path):
    description = read_model_description(str(fmu3_path))
    messages: list[str] = []
    callback = fmi3LogMessageCallback(lambda environment, status, category, message: messages.append(message.decode()))
    slave = FMU3Slave(
        guid=description.guid,
        unzipDirectory=extract(str(fmu3_path), str(tmp_path / "unzipped")),
        modelIdentifier=description.coSimulation.modelIdentifier,
        instanceName="refusals",
    )
    slave.instantiate(logMessage=callback)
    try:
        check_rows(slave.dll, slave.component, table_rows(3), messages)
    finally:
        slave.freeInstance()


def test_every_fmi2_refusal_answers_as_its_row_says(fmu_path, tmp_path):
    description = read_model_description(str(fmu_path))
    messages: list[str] = []
    _MESSAGES["refusals"] = messages
    slave = FMU2Slave(
        guid=description.guid,
        unzipDirectory=extract(str(fmu_path), str(tmp_path / "unzipped")),
        modelIdentifier=description.coSimulation.modelIdentifier,
        instanceName="refusals",
    )
    slave.instantiate(callbacks=_CALLBACKS, loggingOn=True)
    try:
        check_rows(slave.dll, slave.component, table_rows(2), messages)
    finally:
        slave.freeInstance()
        _MESSAGES.pop("refusals", None)
