"""The armour system as one SSP archive (docs/model.md section 11): `python build_fmu.py --system` writes
models/ArmourSystem.ssp with three FMI 2 Co-Simulation FMUs, projectile -> lattice -> hull, connected port to
port, the lattice in load_mode input through its parameter set, and a communication step that keeps the
coupling stable with margin.

    build_system()                   # models/ArmourSystem.ssp
    port_limits()                    # each port's predicted stability limit of explicit coupling (front, back)

The archive holds SystemStructure.ssd (the components, their connectors, the connections, the step for
libcosim's and OMSimulator's fixed-step masters), resources/: the three FMUs and lattice.ssv, the lattice's
parameter set, and OspSystemStructure.xml, the same system in libcosim's own format with the two ports as power
bonds for its ECCO algorithm. It runs in libcosim (`CosimExecution.from_ssp_file`; unzipped,
`CosimExecution.from_osp_config_file("OspSystemStructure.xml")` under ECCO) and in FMPy's `simulate_ssp` (which
applies no parameter binding: pass the lattice's set as `parameter_set`, named `lattice.` + each name).
"""

from __future__ import annotations

import math
import os
import tempfile
import zipfile
from dataclasses import dataclass
from pathlib import Path

from builder.build import MODELS_DIR, build_fmu, resolve_scene
from builder.component import build_component_fmu
from builder.rendering import render
from fmu_src.component_table import component_table
from fmu_src.variables import enumeration_values, loaded_face
from scenes import DEFAULT_SCENE

SYSTEM = "ArmourSystem"
SSD_NAME = "SystemStructure.ssd"
LATTICE_PARAMETER_SET = "resources/lattice.ssv"
# The system's default stop time: the projectile has struck and the backplate force has peaked well before it.
STOP_TIME = 2.0
# How far below the smallest predicted stability limit the default step stays.
STEP_MARGIN = 4.0
OMS = {
    "type": "org.openmodelica",
    "master": "oms-ma",
    "relative_tolerance": "0.0001",
    "namespace": "https://raw.githubusercontent.com/OpenModelica/OMSimulator/master/schema/oms.xsd",
}
OSP = {"type": "com.opensimulationplatform", "namespace": "https://opensimulationplatform.com/SSP/1.0"}


@dataclass(frozen=True)
class Connection:
    source_component: str
    source_variable: str
    target_component: str
    target_variable: str
    bond: str | None = None  # the power bond (force one way, velocity the other) it is half of, if any


# docs/model.md section 11: the projectile pushes the face, the face's motion drives the contact, the backplate
# force pushes the hull, the hull carries the backplate. Each port is a power bond: F_front v_front is the power
# the face takes in, F v the power the hull takes in.
CONNECTIONS = (
    Connection("projectile", "contact_force", "lattice", "F_front", bond="front"),
    Connection("lattice", "x_front", "projectile", "x_front"),
    Connection("lattice", "v_front", "projectile", "v_front", bond="front"),
    Connection("lattice", "backplate_force", "hull", "F", bond="back"),
    Connection("hull", "x", "lattice", "x_back"),
    Connection("hull", "v", "lattice", "v_back", bond="back"),
)
OSP_NAME = "OspSystemStructure.xml"  # libcosim's own system structure, for its ECCO algorithm
# ECCO's settings in OSP_NAME: its step starts at the system's step and may go ECCO_STEP_RANGE times shorter or
# longer; the others are libcosim's own defaults (libcosimpy's EccoParams).
ECCO_STEP_RANGE = 10.0
ECCO_DEFAULTS = (
    ("SafetyFactor", 0.8),
    ("MinimumChangeRate", 0.01),
    ("MaximumChangeRate", 0.2),
    ("ProportionalGain", 0.2),
    ("IntegralGain", 0.15),
    ("RelativeTolerance", 1e-4),
    ("AbsoluteTolerance", 1e-4),
)
COMPONENTS = ("projectile", "lattice", "hull")
# Each component's outputs declared as connectors (the connected ones and those a master records: FMPy's
# simulate_ssp returns the connectors' values only), for the peaks and the system's energy balance.
RECORDED_OUTPUTS = {
    "projectile": ("contact_force", "projectile_position", "projectile_velocity", "face_work"),
    "lattice": (
        "backplate_force",
        "peak_backplate_force",
        "x_front",
        "v_front",
        "external_work",
        "kinetic_energy",
        "potential_energy",
        "dissipated_energy",
        "nonreciprocal_work",
    ),
    "hull": ("x", "v", "dissipated_energy"),
}


@dataclass(frozen=True)
class PortLimit:
    """The predicted stability limit of explicit coupling at one port: a mass `mass` on a coupled spring
    `stiffness` and damper `damping` whose force is held over a step H is stable for H < min(2c/k, 2m/c)."""

    port: str
    what: str  # which mass, spring and damper
    mass: float  # kg
    stiffness: float  # N/m
    damping: float  # N s/m

    @property
    def limit(self) -> float:
        """min(2c/k, 2m/c) in s (infinite where neither bounds it)."""
        bounds = [
            2.0 * self.damping / self.stiffness if self.stiffness > 0 else math.inf,
            2.0 * self.mass / self.damping if self.damping > 0 else math.inf,
        ]
        return min(bounds)


def _edge_weights(count: int) -> list[float]:
    """docs/model.md section 4: 1/2 at either edge, 1 inside (one mass alone: 1)."""
    return [1.0] if count == 1 else [0.5 if i in (0, count - 1) else 1.0 for i in range(count)]


def front_port_mass(scene: str = DEFAULT_SCENE) -> float:
    """The mass the front port moves: F_front pushes each loaded mass a with w_a F_front and x_front = sum of
    w_a ux_a (the weights normalised to 1), so the face answers a force like one body of 1 / sum(w_a^2 / m_a)."""
    interface = resolve_scene(scene).interface()
    starts = {v.name: v.start for v in interface.exposed + interface.fixed}
    face = loaded_face(interface.rows, interface.depth, starts["load_patch"])
    rows, depths = _edge_weights(interface.rows), _edge_weights(interface.depth)
    weights = [rows[i] * depths[k] if face.whole_face else 1.0 for i, k in sorted(face.masses())]
    material = starts["material"][0]
    mass = starts["mass"][material - 1] if isinstance(starts["mass"], tuple) else starts["mass"]
    total = sum(weights)
    return 1.0 / sum((w / total) ** 2 / mass for w in weights)


def port_limits(hull_mass: float | None = None, scene: str = DEFAULT_SCENE) -> tuple[PortLimit, ...]:
    """Each port's limit. Back: the hull (mass m) on the backplate's springs and dampers of the lattice's
    column-C masses in parallel (k_wall, c_wall each), whose force the hull holds over a step (`hull_mass`:
    default the hull table's). Front: the loaded face (front_port_mass) on the projectile's contact, linearised
    at the deepest indentation of the projectile against a rigid face, where the elastic contact has taken its
    kinetic energy, delta = ((n + 1) M v^2 / (2 k_c))^(1 / (n + 1)): stiffness n k_c delta^(n - 1), damping
    lambda k_c delta^n. The projectile's force is a step's mean of its own integration against the face's
    extrapolated motion, which couples more softly than a held force: its limit is a bound, not a sharp one."""
    interface = resolve_scene(scene).interface()
    starts = {v.name: v.start for v in interface.exposed + interface.fixed}
    face = interface.rows * interface.depth
    mass = component_table("hull").variable("m").start if hull_mass is None else hull_mass
    projectile = {v.name: v.start for v in component_table("projectile").variables}
    k_c, n = projectile["contact_stiffness"], projectile["contact_exponent"]
    delta = ((n + 1) * projectile["projectile_mass"] * projectile["projectile_speed"] ** 2 / (2 * k_c)) ** (1 / (n + 1))
    return (
        PortLimit(
            "front",
            "the loaded face's port mass on the linearised contact",
            front_port_mass(scene),
            n * k_c * delta ** (n - 1),
            projectile["contact_damping"] * k_c * delta**n,
        ),
        PortLimit(
            "back",
            f"hull mass on the backplate's {face} springs and dampers",
            float(mass),
            face * float(starts["k_wall"]),
            face * float(starts["c_wall"]),
        ),
    )


def default_step(limits: tuple[PortLimit, ...]) -> float:
    """The largest step of the 1-2-5 series at most the smallest limit over STEP_MARGIN."""
    target = min(limit.limit for limit in limits) / STEP_MARGIN
    if not math.isfinite(target):
        raise ValueError("no port bounds the step: give a hull with a mass and a backplate with a spring")
    decade = 10.0 ** math.floor(math.log10(target))
    return max(decade * factor for factor in (1, 2, 5) if decade * factor <= target * (1 + 1e-12))


@dataclass(frozen=True)
class SystemParameter:
    name: str
    kind: str  # SSV type
    value: int | float
    description: str

    @property
    def text(self) -> str:
        return str(int(self.value)) if self.kind == "Integer" else repr(float(self.value))


def lattice_parameters() -> tuple[SystemParameter, ...]:
    """The lattice's parameter set in the system: driven through its front port (load_mode input, an Integer
    code, which every FMI 2 importer sets)."""
    return (
        SystemParameter(
            "load_mode",
            "Integer",
            enumeration_values("load_mode")["input"],
            "input: the front port's F_front pushes the face (the projectile's contact force)",
        ),
    )


def _components(sources: dict[str, str]) -> list[dict]:
    components = []
    for name in COMPONENTS:
        inputs = [c.target_variable for c in CONNECTIONS if c.target_component == name]
        outputs = [c.source_variable for c in CONNECTIONS if c.source_component == name] + list(RECORDED_OUTPUTS[name])
        connectors = [{"name": n, "kind": "input"} for n in inputs] + [
            {"name": n, "kind": "output"} for n in dict.fromkeys(outputs)
        ]
        components.append(
            {
                "name": name,
                "source": sources[name],
                "connectors": connectors,
                "parameter_set": LATTICE_PARAMETER_SET if name == "lattice" else None,
            }
        )
    return components


def build_system(
    output: str | os.PathLike | None = None, werror: bool = False, lattice_fmu: str | os.PathLike | None = None
) -> Path:
    """Builds the three FMUs (FMI 2; `lattice_fmu`: an already built lattice FMU of the default scene instead)
    and writes the system archive (default models/ArmourSystem.ssp); returns its path."""
    output = Path(output) if output else MODELS_DIR / f"{SYSTEM}.ssp"
    step = default_step(port_limits())
    with tempfile.TemporaryDirectory(prefix="armour_system_") as folder:
        fmus = {
            "projectile": build_component_fmu("projectile", Path(folder) / "Projectile.fmu", werror=werror),
            "hull": build_component_fmu("hull", Path(folder) / "Hull.fmu", werror=werror),
            "lattice": Path(lattice_fmu)
            if lattice_fmu
            else build_fmu(DEFAULT_SCENE, Path(folder) / "MassSpringLattice.fmu", werror=werror),
        }
        sources = {name: f"resources/{path.name}" for name, path in fmus.items()}
        ssd = render(
            "armour_system_ssd.xml",
            system=SYSTEM,
            description="A projectile strikes the lattice, the lattice pushes the hull (docs/model.md section 11)",
            components=_components(sources),
            connections=CONNECTIONS,
            oms=OMS,
            osp=OSP,
            step_size=repr(step),
            stop_time=repr(STOP_TIME),
        )
        ssv = render("armour_system_ssv.xml", name="lattice", parameters=lattice_parameters())
        osp = render(
            "armour_system_osp.xml",
            step_size=repr(step),
            components=[
                {"name": name, "source": sources[name], "parameters": lattice_parameters() if name == "lattice" else ()}
                for name in COMPONENTS
            ],
            connections=sorted(CONNECTIONS, key=lambda c: (c.bond is None, c.bond or "")),
            ecco=(
                ("StepSize", repr(step)),
                ("MinimumStepSize", repr(step / ECCO_STEP_RANGE)),
                ("MaximumStepSize", repr(step * ECCO_STEP_RANGE)),
                *((name, repr(value)) for name, value in ECCO_DEFAULTS),
            ),
        )
        output.parent.mkdir(parents=True, exist_ok=True)
        partial = output.with_suffix(".ssp.partial")
        with zipfile.ZipFile(partial, "w", zipfile.ZIP_DEFLATED) as archive:
            archive.writestr(SSD_NAME, ssd)
            archive.writestr(LATTICE_PARAMETER_SET, ssv)
            archive.writestr(OSP_NAME, osp)
            for name, path in fmus.items():
                archive.write(path, sources[name])
        partial.replace(output)
    return output
