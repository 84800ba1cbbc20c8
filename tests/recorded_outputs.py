"""The FMU's outputs on the published orders, recorded as exact float bits, and the runs that make them.

`python tests/recorded_outputs.py` builds the FMU from the sources and writes tests/data/recorded_outputs.json;
tests/test_recorded_outputs.py rebuilds it and compares. Co-Simulation: both published orders under both
diagonal rules with use_symmetry 0 and 1, at the FMU's defaults over 8 s and at the searches' setting over
1 s. Model Exchange: the same orders and rules driven by the fixed-step importer below, whose arithmetic is
IEEE adds and multiplies only (the same bits on every CPU), so what it records is the FMU's.

Where the bits hold: the FMU's own arithmetic gives the same bits on every x86-64 CPU (its SIMD clones never
contract a multiply and an add, never reassociate), but it calls libm's pow (the adaptive step-size control)
and expm1 (the potential energy), and glibc picks their implementation at load time by the CPU (an FMA
variant where FMA and AVX2 are usable, else FMA4 or SSE2, unless GLIBC_TUNABLES masks them) and changes them
between versions. So the bits are the recorded ones only where the C library, its variant and the machine are
the recording's (`libm_identity`); elsewhere the outputs are compared to the FMU's accuracy.
"""

from __future__ import annotations

import ctypes
import json
import os
import platform
import shutil
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

from fmu_src.published import PUBLISHED_PEAKS  # noqa: E402

DATA = Path(__file__).resolve().parent / "data" / "recorded_outputs.json"
ORDERS = tuple(PUBLISHED_PEAKS)
RULES = ("receiver", "mean")
SETTINGS = {
    "defaults_8s": (8.0, {}),
    "search_1s": (1.0, {"solver": "rkn5", "rtol": 8e-6, "atol": 8e-8}),
}
EXCHANGE_HORIZON, EXCHANGE_STEP = 0.5, 2e-4  # the fixed-step importer: through the peak, stable for RK4
EXCHANGE_SETTING = f"rk4_{EXCHANGE_STEP:g}s_to_{EXCHANGE_HORIZON:g}s"


def libm_identity() -> dict:
    """What decides the bits of the libm functions the FMU calls: machine, C library and glibc's variant."""
    machine = platform.machine().lower()
    variant = "unknown"
    if platform.system() == "Linux" and machine in ("x86_64", "amd64"):
        flags: set[str] = set()
        try:
            for line in Path("/proc/cpuinfo").read_text().splitlines():
                if line.startswith("flags"):
                    flags = set(line.split(":", 1)[1].split())
                    break
        except OSError:
            pass
        variant = "fma" if {"fma", "avx2"} <= flags else "fma4" if "fma4" in flags else "sse2"
    library, version = platform.libc_ver()
    # glibc's tunables can mask CPU features from its own selection (glibc.cpu.hwcaps=-AVX2,-FMA)
    return {
        "machine": machine,
        "system": platform.system(),
        "libc": f"{library} {version}".strip(),
        "libm_variant": variant,
        "glibc_tunables": os.environ.get("GLIBC_TUNABLES"),
    }


def encode(value) -> str | int:
    return value if isinstance(value, int) else float(value).hex()


def decode(value) -> float | int:
    return value if isinstance(value, int) else float.fromhex(value)


def co_simulation_run(fmu, setting: str, order, rule: str, symmetry: int) -> dict:
    """One Co-Simulation run of the record on a LatticeFMU: all the FMU's outputs at its end, by name."""
    horizon, parameters = SETTINGS[setting]
    return fmu.simulate(
        order, horizon=horizon, parameters={**parameters, "diagonal_rule": rule, "use_symmetry": symmetry}
    ).values


CO_SIMULATION_CASES = [
    (setting, order, rule, symmetry)
    for setting in SETTINGS
    for order in ORDERS
    for rule in RULES
    for symmetry in (0, 1)
]
MODEL_EXCHANGE_CASES = [(order, rule) for order in ORDERS for rule in RULES]


def co_simulation_runs(fmu_path) -> list[dict]:
    from orchestrator.simulation import LatticeFMU

    with LatticeFMU(fmu_path) as fmu:
        return [
            {
                "interface": "co-simulation",
                "setting": setting,
                "order": list(order),
                "diagonal_rule": rule,
                "use_symmetry": symmetry,
                "outputs": {
                    name: encode(value)
                    for name, value in co_simulation_run(fmu, setting, order, rule, symmetry).items()
                },
            }
            for setting, order, rule, symmetry in CO_SIMULATION_CASES
        ]


def _pointer(array):
    return array.ctypes.data_as(ctypes.POINTER(ctypes.c_double))


def fixed_step_exchange(fmu_path, order, rule, horizon=EXCHANGE_HORIZON, step=EXCHANGE_STEP) -> dict:
    """Model Exchange under classical RK4 with a fixed step: an event is handled at the end of the step in
    which an indicator changed sign (not located), the load's time event at the first step end at or after
    it. Returns every output at the end."""
    from fmpy import extract, read_model_description
    from fmpy.fmi2 import FMU2Model

    description = read_model_description(str(fmu_path))
    variables = {v.name: v for v in description.modelVariables}
    unzip_dir = extract(str(fmu_path))
    model = FMU2Model(
        guid=description.guid,
        unzipDirectory=unzip_dir,
        modelIdentifier=description.modelExchange.modelIdentifier,
        instanceName="fixed-step",
    )
    nx, nz = description.numberOfContinuousStates, description.numberOfEventIndicators
    x, dx, k = np.zeros(nx), np.zeros(nx), [np.zeros(nx) for _ in range(4)]
    z, z_before = np.zeros(nz), np.zeros(nz)
    try:
        model.instantiate()
        model.setupExperiment(startTime=0.0)
        model.enterInitializationMode()
        model.setInteger([variables[f"material[{j}]"].valueReference for j in range(1, len(order) + 1)], list(order))
        model.setInteger([variables["diagonal_rule"].valueReference], [RULES.index(rule)])
        model.exitInitializationMode()
        event = model.newDiscreteStates()
        next_time = event[5] if event[4] else np.inf
        model.enterContinuousTimeMode()
        model.getContinuousStates(_pointer(x), nx)
        model.getEventIndicators(_pointer(z_before), nz)
        steps = int(round(horizon / step))
        for i in range(steps):
            t = i * step
            for stage, (offset, weight) in enumerate(((0.0, 0.0), (0.5, 0.5), (0.5, 0.5), (1.0, 1.0))):
                state = x if stage == 0 else x + weight * step * k[stage - 1]
                model.setTime(t + offset * step)
                model.setContinuousStates(_pointer(state), nx)
                model.getDerivatives(_pointer(dx), nx)
                k[stage][:] = dx
            x = x + step / 6.0 * (k[0] + 2.0 * k[1] + 2.0 * k[2] + k[3])
            t = (i + 1) * step
            model.setTime(t)
            model.setContinuousStates(_pointer(x), nx)
            model.completedIntegratorStep()
            model.getEventIndicators(_pointer(z), nz)
            if t >= next_time or np.any((z > 0) != (z_before > 0)):
                model.enterEventMode()
                event = model.newDiscreteStates()
                next_time = event[5] if event[4] else np.inf
                model.enterContinuousTimeMode()
                model.getEventIndicators(_pointer(z), nz)
            z_before[:] = z
        outputs = [v for v in description.modelVariables if v.causality == "output"]
        reals = [v for v in outputs if v.type == "Real"]
        integers = [v for v in outputs if v.type == "Integer"]
        values = dict(zip((v.name for v in reals), model.getReal([v.valueReference for v in reals])))
        values.update(zip((v.name for v in integers), model.getInteger([v.valueReference for v in integers])))
        return values
    finally:
        model.freeInstance()
        shutil.rmtree(unzip_dir, ignore_errors=True)


def model_exchange_runs(fmu_path) -> list[dict]:
    return [
        {
            "interface": "model-exchange",
            "setting": EXCHANGE_SETTING,
            "order": list(order),
            "diagonal_rule": rule,
            "outputs": {name: encode(value) for name, value in fixed_step_exchange(fmu_path, order, rule).items()},
        }
        for order, rule in MODEL_EXCHANGE_CASES
    ]


def record(fmu_path) -> dict:
    return {"environment": libm_identity(), "runs": co_simulation_runs(fmu_path) + model_exchange_runs(fmu_path)}


def main() -> int:
    import tempfile

    from builder.build import build_fmu

    with tempfile.TemporaryDirectory(prefix="record_outputs_") as folder:
        data = record(build_fmu(output=Path(folder) / "MassSpringLattice.fmu"))
    runs = ",\n  ".join(json.dumps(run) for run in data["runs"])  # a run a line: diffs show which changed
    DATA.write_text(f'{{"environment": {json.dumps(data["environment"])},\n "runs": [\n  {runs}\n ]\n}}\n')
    print(f"{DATA}: {len(data['runs'])} runs")
    return 0


if __name__ == "__main__":
    sys.exit(main())
