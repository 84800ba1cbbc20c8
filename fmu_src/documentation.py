"""documentation/index.html inside the FMU: the model in a page, every variable, the published numbers, a chart.

`build_fmu.py` calls `documentation_html` after compiling: the variables come from the one table
(fmu_src/variables.py), and the numbers and the chart from simulating the binary just built (about a
second), so the page describes the FMU it ships in.
"""
from __future__ import annotations

import html
import io
from pathlib import Path

from fmu_src.variables import INDICATOR, Interface

# The study's published peaks (8 s, 0.01 s samples, receiver rule, load angle 0), which the defaults reproduce.
PUBLISHED = {(1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11): 1747.779979851872,
             (1, 7, 5, 9, 3, 6, 11, 8, 2, 4, 10): 1497.8867334973704}

MODEL = """
<p>An R x C grid of 1 kg point masses, one material per column, joined to up to eight neighbours by
exponential springs <code>f(r) = k (exp(&alpha;|r|) - 1) r/|r|</code> (r the difference of the two
displacements), with dampers on the nearest neighbours. Column 1 is pushed with <code>F_total</code> at
<code>load_angle</code> for 0 &le; t &le; <code>t_active</code> (half weight on the first and last row); column C
meets a rigid backplate <code>backplate_gap</code> behind it, which pushes back with
<code>k_wall p + c_wall max(vx, 0)</code> while a mass penetrates it by p &gt; 0. The output
<code>backplate_force</code> is the sum of those forces; <code>peak_backplate_force</code> is its maximum over
samples every <code>peak_sample_interval</code>, as the study computed its numbers.</p>
<p>Material m has scale s = (2/3)<sup>m-1</sup>: k = 100 s N, k_diag = 50 s N, c = 5 s N s/m,
&alpha; = &alpha;_diag = 10 1/m; the horizontal springs are k0 = 100 N, &alpha;0 = 10 1/m, c0 = 5 N s/m.
<code>material[j]</code> is the material of column j: a permutation of 1..C.</p>
<h3>The diagonal rule (read this before comparing numbers)</h3>
<p>With <code>diagonal_rule = receiver</code> (the default) a diagonal spring takes its constants from the
column of the mass it acts on, so a diagonal between two different materials pushes its ends with unequal
forces: it is not reciprocal and does work of its own (<code>nonreciprocal_work</code>, about -114 J of
303 J put in for the published best order). That is how the study computed its published numbers, and their
ranking depends on it. With <code>diagonal_rule = mean</code> both ends use the mean of the two columns'
constants (physically reciprocal): the peaks roughly double and the ranking changes. Every result should say
which rule it used.</p>
<h3>Two interfaces from one model</h3>
<p><b>Co-Simulation</b>: the FMU integrates with its own solver (<code>solver</code>: adaptive DOP853 by
default, <code>rtol</code>, <code>atol</code>), stops exactly at the load switch-off, locates every backplate
contact and damping switch as an event, and reads samples and peaks from the dense output, so one doStep over
the horizon gives the same numbers as many small ones. With <code>use_symmetry = 1</code> (the default) it
integrates no more of the lattice than the scene needs: under a load along x (<code>load_angle = 0</code>) no
mass ever moves in y (a spring's <code>r = u_b - u_a</code> has no y part while no mass has moved in y), so
<code>uy</code> and <code>vy</code> are left out; with an odd number of rows the lattice is also
mirror-symmetric about its middle row, so only the upper half is integrated. The error norms count each kept
component for the ones it stands for, so the steps are those of the whole lattice and the outputs agree with
<code>use_symmetry = 0</code> to rounding over the search horizon (to the tolerance over long runs); the whole
lattice's state is rebuilt for every output. The armour scene's evaluation then costs about half as much.</p>
<p><b>Model Exchange</b>: the importer's solver integrates the same equations. The continuous states are the
displacements <code>ux</code>, <code>uy</code>, the velocities <code>vx</code>, <code>vy</code> and the three
energy integrals (<code>external_work</code>, <code>dissipated_energy</code>, <code>nonreciprocal_work</code>),
so the energy balance closes to the importer's accuracy. The event indicators are each row's contact
(<code>contact_indicator</code>) and damping (<code>damping_indicator</code>) switch, and the load switch-off is
a time event. The FMU sees only the points the importer stops at: in Model Exchange
<code>peak_backplate_force</code> is the maximum over the sample times among the points at which the importer
completed a step or handled an event (an importer that stops on the sample grid, as FMPy does on its output
grid, gives the study's sampled peak to its own accuracy), and <code>peak_backplate_force_continuous</code> the
maximum over all those points, which can miss a maximum between them. <code>solver</code>, <code>rtol</code>,
<code>atol</code>, <code>fixed_step</code>, <code>peak_force_limit</code> and <code>use_symmetry</code> are not
used: the importer integrates the whole lattice.</p>
"""


def _variables_table(interface: Interface) -> str:
    rows = []
    for variable in interface.exposed:
        if variable.role == INDICATOR or variable.name.startswith("der("):
            kind = "local"
        else:
            kind = variable.causality
        if variable.enumeration:
            values = ", ".join(f"{code} = {html.escape(name)}" for code, (name, _) in enumerate(variable.items))
            type_text = f"Enumeration {html.escape(variable.enumeration)}"
        else:
            values = "" if variable.causality != "parameter" else html.escape(variable.allowed_text())
            type_text = variable.type
        start = variable.start
        if isinstance(start, tuple):
            start = ", ".join(f"{value:g}" for value in start)
        elif start is not None:
            start = f"{start:g}"
        size = "" if variable.size is None else "[" + ", ".join(str(n) for n in (variable.shape or (variable.size,))) + "]"
        rows.append(f"<tr><td><code>{html.escape(variable.name)}{size}</code></td><td>{type_text}</td>"
                    f"<td>{kind}</td><td>{html.escape(variable.unit or '')}</td><td>{html.escape(start or '')}</td>"
                    f"<td>{values}</td><td>{html.escape(variable.description)}</td></tr>")
    fixed = ", ".join(f"<code>{html.escape(v.name)}</code>" for v in interface.fixed)
    head = ("<tr><th>name</th><th>type</th><th>causality</th><th>unit</th><th>start</th><th>allowed</th>"
            "<th>description</th></tr>")
    note = f"<p>Compiled in as constants (this scene does not expose them): {fixed}.</p>" if fixed else ""
    return f"<table>{head}{''.join(rows)}</table>{note}"


def _simulate(fmu: Path, fmi_version: int, order, stop_time: float, output: list[str]):
    from fmpy import simulate_fmu

    start = {}
    if order is not None:
        start = {"material": list(order)} if fmi_version == 3 else {
            f"material[{j}]": m for j, m in enumerate(order, start=1)}
    return simulate_fmu(str(fmu), stop_time=stop_time, output_interval=0.01, start_values=start, output=output)


def _chart_svg(curves: dict[str, tuple], ylabel: str) -> str:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    figure, axes = plt.subplots(figsize=(7.5, 3.6))
    for label, (time, values) in curves.items():
        axes.plot(time, values, label=label, linewidth=1.2)
    axes.set_xlabel("time (s)")
    axes.set_ylabel(ylabel)
    axes.grid(alpha=0.3)
    axes.legend(fontsize=8)
    figure.tight_layout()
    buffer = io.StringIO()
    figure.savefig(buffer, format="svg")
    plt.close(figure)
    text = buffer.getvalue()
    return text[text.index("<svg"):]


def documentation_html(fmu: Path, fmi_version: int, interface: Interface, identifier: str, scene) -> str:
    """The page for the FMU at `fmu` (already built): simulates it for the numbers and the chart."""
    names = {v.name for v in interface.exposed}
    orders = [None]
    reproduces = ""
    published_scene = ("material" in names and interface.rows == interface.cols == 11 and "backplate_force" in names
                       and not set(scene.parameters) & {"k", "k_diag", "c", "alpha", "alpha_diag"})
    if published_scene:
        orders = list(PUBLISHED)
    has_force = "backplate_force" in names and "contact_indicator" in names
    signal = "backplate_force" if has_force else "ux_right_edge"
    outputs = [signal] + (["peak_backplate_force"] if has_force else [])
    curves, table, failed = {}, [], ""
    try:
        for order in orders:
            result = _simulate(fmu, fmi_version, order, scene.horizon, outputs)
            label = "default start values" if order is None else f"material = {list(order)}"
            window = result["time"] <= min(scene.horizon, 1.0) if has_force else result["time"] >= 0
            curves[label] = (result["time"][window], result[signal][window])
            if order is not None:
                peak = float(result["peak_backplate_force"][-1])
                table.append(f"<tr><td><code>{list(order)}</code></td><td>{PUBLISHED[order]:.6f}</td>"
                             f"<td>{peak:.6f}</td><td>{peak - PUBLISHED[order]:.1e}</td></tr>")
    except Exception as failure:  # e.g. a scene whose compiled-in values the model refuses: say so, build on
        curves, table = {}, []
        failed = html.escape(f"{type(failure).__name__}: {failure}")
    if table:
        reproduces = (
            "<h2>The published numbers it reproduces</h2><p>The study's peaks (8 s, samples every 0.01 s, receiver "
            "rule, load angle 0) against this FMU's <code>peak_backplate_force</code> at its default settings "
            "(Co-Simulation, DOP853, rtol 1e-7), computed when the FMU was built:</p><table><tr><th>order</th>"
            "<th>published (N)</th><th>this FMU (N)</th><th>difference (N)</th></tr>" + "".join(table) + "</table>")
    unit = "N" if has_force else "m"
    if curves:
        chart = _chart_svg(curves, f"{signal} ({unit})")
    else:
        chart = f"<p><b>Not computed</b>: simulating this FMU at its default settings failed when it was built ({failed}).</p>"
    description = html.escape(scene.description or f"{interface.rows} x {interface.cols} mass-spring lattice")
    return f"""<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8"><title>{identifier}</title>
<style>body{{font-family:sans-serif;max-width:70em;margin:2em auto;line-height:1.4}}
table{{border-collapse:collapse;font-size:0.85em}}td,th{{border:1px solid #ccc;padding:2px 6px;vertical-align:top}}
code{{font-size:0.95em}}</style></head><body>
<h1>{identifier}</h1>
<p>{description}. FMI {fmi_version}.0, Model Exchange and Co-Simulation, {interface.rows} x {interface.cols}
masses.</p>
<h2>The model</h2>{MODEL}
{reproduces}
<h2>{signal} over time</h2>
<p>Simulated with this FMU (Co-Simulation, default settings) when it was built{", first second" if has_force else ""}.</p>
{chart}
<h2>Variables</h2>
{_variables_table(interface)}
</body></html>
"""
