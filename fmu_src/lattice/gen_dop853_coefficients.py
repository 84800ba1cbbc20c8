"""Regenerate dop853_coefficients.h from SciPy's table, so the C solver and SciPy share exact coefficients.

Run once by hand when the table changes (never at build time: the FMU sources must not need SciPy).
"""

from pathlib import Path

import numpy as np
from scipy.integrate._ivp import dop853_coefficients as coefficients


def c_array(name, values):
    values = np.asarray(values, dtype=float)
    if values.ndim == 1:
        body = ",\n    ".join(repr(float(x)) for x in values)
        return f"static const double {name}[{len(values)}] = {{\n    {body}\n}};\n"
    rows = ",\n".join("    {" + ", ".join(repr(float(x)) for x in row) + "}" for row in values)
    return f"static const double {name}[{values.shape[0]}][{values.shape[1]}] = {{\n{rows}\n}};\n"


def main():
    lines = [
        "/* Coefficients of Hairer's DOP853 (8th order, embedded 5th and 3rd order error estimators, 7th order",
        " * dense output), as tabulated in SciPy's scipy/integrate/_ivp/dop853_coefficients.py (BSD-3-Clause),",
        " * printed with repr() so every double is exact. Regenerate with "
        "fmu_src/lattice/gen_dop853_coefficients.py. */",
        "#ifndef DOP853_COEFFICIENTS_H",
        "#define DOP853_COEFFICIENTS_H",
        "",
        f"#define DOP853_N_STAGES {coefficients.N_STAGES}",
        f"#define DOP853_N_STAGES_EXTENDED {coefficients.N_STAGES_EXTENDED}",
        f"#define DOP853_INTERPOLATOR_POWER {coefficients.INTERPOLATOR_POWER}",
        "",
    ]
    for name in ("C", "A", "B", "E3", "E5", "D"):
        lines.append(c_array(f"DOP853_{name}", getattr(coefficients, name)))
    lines.append("#endif\n")
    Path(__file__).with_name("dop853_coefficients.h").write_text("\n".join(lines))


if __name__ == "__main__":
    main()
