"""How the projectile's contact stiffness shapes the force it puts on the lattice, beside the study's pulse.

    python -m bench.projectile_contact            # about 10 s: six stiffnesses over 1 s in steps of 1 ms
    python -m bench.projectile_contact --quick    # about 5 s: three stiffnesses

Why: projectile mode (docs/model.md section 11) replaces the pulse's prescribed force by a body that answers
back. Its default carries the pulse's momentum (projectile_mass x projectile_speed = F_total x t_active); the
contact stiffness then decides how the momentum is delivered: a stiff contact a short, high force, a soft one a
long, low force. The default stiffness is the one whose contact force is nearest the pulse in both size and
duration, on the study's 11 x 11 lattice with its published order. The FMU runs in projectile mode with its
defaults but the stiffness, the contact force read every 1 ms; per stiffness: the contact force's peak, how long
it stays above half of that peak, how long the first contact lasts and the impulse it delivers, and the sampled
peak backplate force. The pulse's row is the same quantities of its 1200 N for 0.15 s.
"""

from __future__ import annotations

import shutil

from fmpy import extract, read_model_description
from fmpy.fmi2 import FMU2Slave

from fmu_src.variables import PROJECTILE_CONTACT_STIFFNESS, enumeration_values

from .common import add_fmu_option, lattice_fmu
from .measurements import Page, Run, Table, write_page

STIFFNESSES = (1e4, 2e4, 3e4, 5e4, 1e5, 2e5)
HORIZON, READ_STEP = 1.0, 1e-3


def contact_history(path, stiffness: float | None) -> dict:
    """One run over HORIZON read every READ_STEP: projectile mode with `stiffness`, or the pulse (None)."""
    description = read_model_description(str(path))
    vr = {v.name: v.valueReference for v in description.modelVariables}
    starts = {v.name: float(v.start) for v in description.modelVariables if v.start is not None}
    unzip_dir = extract(str(path))
    slave = FMU2Slave(
        guid=description.guid,
        unzipDirectory=unzip_dir,
        modelIdentifier=description.coSimulation.modelIdentifier,
        instanceName="contact",
    )
    try:
        slave.instantiate()
        slave.setupExperiment(startTime=0.0, stopTime=HORIZON)
        slave.enterInitializationMode()
        if stiffness is not None:
            slave.setInteger([vr["load_mode"]], [enumeration_values("load_mode")["projectile"]])
            slave.setReal([vr["contact_stiffness"]], [stiffness])
        slave.exitInitializationMode()
        forces = []
        for i in range(round(HORIZON / READ_STEP)):
            t = i * READ_STEP
            forces.append(
                starts["F_total"]
                if stiffness is None and t < starts["t_active"]
                else slave.getReal([vr["contact_force"]])[0]
            )
            slave.doStep(t, READ_STEP)
        peak_backplate = slave.getReal([vr["peak_backplate_force"]])[0]
        slave.terminate()
    finally:
        slave.freeInstance()
        shutil.rmtree(unzip_dir, ignore_errors=True)
    first_end = next((i for i, force in enumerate(forces) if i > 0 and force <= 0.0), len(forces))
    first = forces[:first_end]
    peak = max(first)
    return {
        "peak": peak,
        "above_half": sum(force > 0.5 * peak for force in first) * READ_STEP,
        "duration": first_end * READ_STEP,
        "impulse": sum(first) * READ_STEP,
        "peak_backplate": peak_backplate,
    }


def main(argv=None) -> int:
    run = Run.start(__file__, argv)
    parser = run.parser(__doc__, quick="three stiffnesses (the default, a softer and a stiffer one)")
    add_fmu_option(parser)
    args = parser.parse_args(argv)
    stiffnesses = (1e4, PROJECTILE_CONTACT_STIFFNESS, 1e5) if args.quick else STIFFNESSES
    with lattice_fmu(args.fmu) as path:
        pulse = contact_history(path, None)
        rows = [
            (
                "the pulse (load_mode pulse)",
                "",
                f"{pulse['peak']:.0f}",
                f"{pulse['above_half']:.3f}",
                f"{pulse['duration']:.3f}",
                f"{pulse['impulse']:.1f}",
                f"{pulse['peak_backplate']:.2f}",
            )
        ]
        measured = {}
        for stiffness in stiffnesses:
            measured[stiffness] = result = contact_history(path, stiffness)
            rows.append(
                (
                    "projectile" + (" (the default)" if stiffness == PROJECTILE_CONTACT_STIFFNESS else ""),
                    f"{stiffness:g}",
                    f"{result['peak']:.0f}",
                    f"{result['above_half']:.3f}",
                    f"{result['duration']:.3f}",
                    f"{result['impulse']:.1f}",
                    f"{result['peak_backplate']:.2f}",
                )
            )
    default = measured[PROJECTILE_CONTACT_STIFFNESS]
    page = Page(
        name=run.name,
        title="The projectile's contact beside the pulse",
        headline=(
            f"the default projectile (contact_stiffness {PROJECTILE_CONTACT_STIFFNESS:g} N/m^1.5) pushes with "
            f"at most {default['peak']:.0f} N, above half of that for {default['above_half']:.3f} s (the "
            f"pulse: {pulse['peak']:.0f} N for {pulse['above_half']:.3f} s)"
        ),
        summary=(
            f"The study's 11 x 11 lattice in its default order, projectile mode with the FMU's defaults (the "
            f"pulse's momentum) but contact_stiffness, over {HORIZON:g} s; the contact force read every "
            f"{READ_STEP * 1e3:g} ms (the pulse: its prescribed force on the same grid). The first contact "
            "ends where the force first returns to 0; the body may strike again later, when the lattice "
            "rebounds from the backplate. Peak backplate force: the FMU's sampled peak (every 0.01 s)."
        ),
        tables=(
            Table(
                (
                    "load",
                    "contact_stiffness (N/m^1.5)",
                    "peak force (N)",
                    "above half its peak (s)",
                    "first contact (s)",
                    "impulse of the first contact (N s)",
                    "peak backplate force (N)",
                ),
                tuple(rows),
            ),
        ),
    )
    write_page(run, page)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
