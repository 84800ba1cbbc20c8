"""A study: the user's case, and a list of steps run on it.

The study owns no loop of its own: each step (``orchestrator/steps/``) is one feature with a frozen config
(its command-line options), a ``run(context)`` that simulates only through ``context.evaluator`` (the one
Evaluator: cache, journal, bounded in-flight work, time limits, dead-worker recovery, resume) and a frozen
result. The study runs the steps that apply in order (a step may do the work of another in a run:
``replaces``); a later step reads earlier results by their step (``context.result(Searches)``); a finished
study has an answer when, asked in order, a step's ``verdict`` holds one before any refuses it. Searches rank
by the objective's search fidelity; every number reported as a result is at full fidelity (the whole scene at
the FMU's default accuracy).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Any, ClassVar

from fmu_src.core import MAX_COLS
from fmu_src.materials import BOUND_SUFFIXES, STUDY_MATERIAL_COUNT, MaterialTable
from fmu_src.variables import WHOLE_FACE, LoadedFace, enumeration_values, loaded_face
from scenes import DEFAULT_SCENE, PROJECTILE_SCENE, Scene

from .design import DesignSpace
from .fmu import PreparedFMU
from .interruption import raise_if_requested
from .loop import Evaluator, EvaluatorState
from .objective import AGGREGATES, SEARCH_HORIZON, SEARCH_RTOL, LatticeObjective, ObjectiveDescription, expand_cases
from .options import check_options, given, integer, number, option
from .progress import Progress
from .scene import ResolvedScene, check_load_patch

MAX_HORIZON = 3600.0  # s: a longer horizon is refused (one evaluation must end)
MAX_RUNS_PER_DESIGN = 1000  # FMU runs per design (the product of --case) beyond which --confirm-cost is needed
SCENE_OPTIONS = {
    "F_total": "--load",
    "load_angle": "--load-angle",
    "load_patch": "--load-patch",
    "load_mode": "--load-mode",
    "projectile_mass": "--projectile-mass",
    "projectile_speed": "--projectile-speed",
    "contact_stiffness": "--contact-stiffness",
    "contact_exponent": "--contact-exponent",
    "contact_damping": "--contact-damping",
}
# The CaseConfig field of each of SCENE_OPTIONS' parameters.
SCENE_OPTION_FIELDS = {
    "F_total": "load",
    "load_angle": "load_angle",
    "load_patch": "load_patch",
    "load_mode": "load_mode",
    "projectile_mass": "projectile_mass",
    "projectile_speed": "projectile_speed",
    "contact_stiffness": "contact_stiffness",
    "contact_exponent": "contact_exponent",
    "contact_damping": "contact_damping",
}
# What loads column 1 (docs/model.md section 11), by the FMU's load_mode items.
LOAD_MODES = tuple(enumeration_values("load_mode"))
PULSE, INPUT, PROJECTILE = "pulse", "input", "projectile"
# The parameters of the projectile and its contact: they act only under a projectile.
PROJECTILE_PARAMETERS = (
    "projectile_mass",
    "projectile_speed",
    "contact_stiffness",
    "contact_exponent",
    "contact_damping",
)
# The parameters of the prescribed pulse: a projectile brings its own momentum, so they act only under a pulse.
PULSE_PARAMETERS = ("F_total", "load_angle", "t_active")
# The rule whose answer is the design file by default: the reciprocal one (Newton's third law holds on every
# diagonal spring). The FMU's own default stays the study's rule, which reproduces its published numbers.
DESIGN_RULE = "mean"


def _default_scene_values() -> tuple[float, float, float]:
    """The default scene's load, load angle and horizon, as ``--help`` shows them beside "the scene's"."""
    scene = Scene.load(DEFAULT_SCENE)
    values = scene.parameter_values()
    return values["F_total"], values["load_angle"], scene.horizon


_LOAD, _LOAD_ANGLE, _HORIZON = _default_scene_values()
# The scene that carries each load mode's search horizon (python -m bench.horizon_study for the pulse, python -m
# bench.projectile_finding for the projectile).
LOAD_MODE_SCENES = {PULSE: DEFAULT_SCENE, PROJECTILE: PROJECTILE_SCENE}


@dataclass(frozen=True)
class SearchFidelity:
    """The searches' cheaper evaluation: its horizon (s) and its solver tolerance."""

    horizon: float
    rtol: float


def search_fidelity(mode: str, scene: Scene | None = None) -> SearchFidelity:
    """The searches' horizon and tolerance under ``mode`` (pulse or projectile): ``scene``'s own where it gives
    them for that mode (its load_mode's default), else those of the mode's scene (LOAD_MODE_SCENES)."""
    reference = Scene.load(LOAD_MODE_SCENES[mode])
    carrier = reference
    if scene is not None and scene.parameter_values().get("load_mode", 0) == enumeration_values("load_mode")[mode]:
        carrier = scene
    return SearchFidelity(
        carrier.search_horizon or reference.search_horizon or SEARCH_HORIZON,
        carrier.search_rtol or reference.search_rtol or SEARCH_RTOL,
    )


_PROJECTILE = Scene.load(PROJECTILE_SCENE).parameter_values()  # the default projectile, as --help shows it
_PULSE_SEARCH, _PROJECTILE_SEARCH = search_fidelity(PULSE), search_fidelity(PROJECTILE)


@dataclass(frozen=True)
class CaseConfig:
    """The case the user asks about: scene, lattice and materials, objective, diagonal rules, load."""

    scene: str = option(DEFAULT_SCENE, "scene name from scenes/ or the path of a scene .json file", path=True)
    fmu: str | None = option(
        None,
        "the FMU to use (never rebuilt)",
        show_default="the scene's FMU in models/, built or rebuilt as needed",
        path=True,
    )
    materials: str | None = option(
        None,
        "material table: a .csv with the header name,k,k_diag,c,alpha,alpha_diag "
        "(units as docs/model.md section 3), or .toml / .json with the same fields",
        show_default=f"the study's {STUDY_MATERIAL_COUNT} materials",
        path=True,
    )
    cols: int | None = option(
        None,
        "columns of the lattice (materials per design)",
        show_default="the scene's",
        type=integer("--cols", 2, MAX_COLS),
    )
    depth: int | None = option(
        None,
        "masses through the plate's depth, z (docs/model.md section 10: each layer, one "
        "column of one material, is a sheet of rows x depth masses; 1: the 2-D lattice), "
        "fixed when its FMU is built",
        show_default="the scene's",
        type=integer("--depth", 1),
    )
    repeat: bool = option(
        False,
        "a material may fill several columns (M^C designs; default: each material at most once)",
        action="store_true",
    )
    objective: str = option(
        "sampled",
        "FMU output(s) to minimise, one or two or three separated by commas: sampled "
        "(peak_backplate_force over the 0.01 s samples, the study's), continuous "
        "(peak_backplate_force_continuous), max_compression, mass (stack_mass: with --vary, the front of the "
        "peak against the stack's mass)",
        metavar="OUTPUT[,OUTPUT]",
    )
    diagonal_rules: tuple[str, ...] = option(
        (),
        "diagonal rules to search under, each with equal weight; the first is the design you build (best_design.ssp)",
        flag="--diagonal-rule",
        nargs="+",
        metavar="RULE",
        show_default=f"every rule of the FMU, the reciprocal {DESIGN_RULE} rule first: mean receiver",
    )
    load: float | None = option(
        None, "total load F_total in N", show_default=f"the scene's, {_LOAD:g} N", metavar="N", type=number("--load")
    )
    load_angle: float | None = option(
        None,
        "load angle in degrees (0: along +x)",
        show_default=f"the scene's, {_LOAD_ANGLE:g}",
        metavar="DEG",
        type=number("--load-angle"),
    )
    load_patch: int | None = option(
        None,
        "where column 1 is loaded: 0 over its whole face, an odd P over the "
        "centred P x P patch of its rows x depth masses",
        show_default="the scene's",
        metavar="P",
        type=integer("--load-patch", 0),
    )
    load_mode: str | None = option(
        None,
        "what strikes column 1 (docs/model.md section 11): pulse, the force --load "
        "for t_active (the study's); projectile, a rigid body of --projectile-mass at "
        "--projectile-speed whose contact force answers the lattice; input (F_front set "
        "by another FMU) needs a co-simulation master and is refused here",
        choices=LOAD_MODES,
        show_default="the scene's, pulse",
    )
    projectile_mass: float | None = option(
        None,
        "the projectile's mass in kg (only under a projectile)",
        show_default=f"the FMU's, {_PROJECTILE['projectile_mass']:g} kg",
        metavar="KG",
        type=number("--projectile-mass", 0),
    )
    projectile_speed: float | None = option(
        None,
        "the projectile's speed along +x in m/s as it touches the face at t = 0 (only under a projectile)",
        show_default=f"the FMU's, {_PROJECTILE['projectile_speed']:g} m/s",
        metavar="M/S",
        type=number("--projectile-speed", 0),
    )
    contact_stiffness: float | None = option(
        None,
        "k_c of the Hunt-Crossley contact k_c d^n (1 + lambda d') in N/m^n (only under a projectile)",
        show_default=f"the FMU's, {_PROJECTILE['contact_stiffness']:g}",
        metavar="K",
        type=number("--contact-stiffness", 0),
    )
    contact_exponent: float | None = option(
        None,
        "n of the contact (only under a projectile)",
        show_default=f"the FMU's, {_PROJECTILE['contact_exponent']:g}",
        metavar="N",
        type=number("--contact-exponent", 0),
    )
    contact_damping: float | None = option(
        None,
        "lambda of the contact in s/m (only under a projectile)",
        show_default=f"the FMU's, {_PROJECTILE['contact_damping']:g} s/m",
        metavar="S/M",
        type=number("--contact-damping", 0, low_inclusive=True),
    )
    horizon: float | None = option(
        None,
        f"simulated time of the full scene in s, at most {MAX_HORIZON:g}",
        show_default=f"the scene's, {_HORIZON:g} s",
        metavar="S",
        type=number("--horizon", 0, MAX_HORIZON),
    )
    search_horizon: float | None = option(
        None,
        "horizon of the searches' cheaper objective in s (every reported "
        "number is re-evaluated over the full horizon); 0: the full horizon",
        show_default=f"the scene's for its load: {_PULSE_SEARCH.horizon:g} s under "
        f"the study's pulse, {_PROJECTILE_SEARCH.horizon:g} s under a projectile",
        metavar="S",
        type=number("--search-horizon", 0, MAX_HORIZON, allow_zero=True),
    )
    search_rtol: float | None = option(
        None,
        "solver tolerance of the searches' cheaper objective; 0: the FMU's default",
        show_default=f"the scene's for its load: {_PULSE_SEARCH.rtol:g} "
        f"under the study's pulse, {_PROJECTILE_SEARCH.rtol:g} under a projectile",
        metavar="RTOL",
        type=number("--search-rtol", 1e-13, 1e-2, allow_zero=True),
    )
    case: tuple[str, ...] = option(
        (),
        "load cases: NAME=V1,V2,... (repeatable; the cases are the product of the "
        "lists), NAME a scalar parameter of the FMU",
        action="append",
        metavar="NAME=V1,V2",
    )
    aggregate: str | None = option(
        None, "how the load cases make one value (only with --case)", choices=AGGREGATES, show_default="worst"
    )

    def __post_init__(self):
        check_options(self)
        if self.aggregate is not None and not self.case:
            raise ValueError("--aggregate: only with --case (there is one case to aggregate)")
        if self.load_mode == INPUT:
            raise ValueError(
                f"--load-mode {INPUT}: input mode needs a co-simulation master to set F_front (another "
                f"FMU pushing the lattice), which a search is not; allowed here: {PULSE}, {PROJECTILE}"
            )


@dataclass(frozen=True)
class Case:
    """The user's case, resolved against the FMU: every value checked, the defaults filled in, the parameters
    the FMU would use anyway left out (so that spelling out a default resumes the same run)."""

    scene: str
    rows: int
    columns: int
    materials: MaterialTable
    space: DesignSpace
    outputs: tuple[str, ...]
    rules: tuple[str, ...]  # searched, each with equal weight; the first is the design's
    rule_default: str  # the FMU's own default rule
    parameters: dict[str, Any]  # non-default FMU parameters of every run (the diagonal rule comes per rule)
    case_lists: dict[str, tuple[Any, ...]]
    aggregate: str
    horizon: float
    search_horizon: float | None
    search_rtol: float | None
    depth: int = 1  # masses along z (docs/model.md section 10); 1: the 2-D lattice
    # the FMU's own defaults that are not the study's scene's (a scene's load, patch, backplate...): a known
    # optimum of the study holds for none of them
    departures: tuple[str, ...] = ()
    load_mode: str = PULSE  # what strikes column 1 in every run (with --case load_mode=...: the first case's)

    @property
    def cases(self) -> list[dict]:
        return expand_cases(self.case_lists)

    @property
    def rule_in_cases(self) -> bool:
        return "diagonal_rule" in self.case_lists

    def objective(self, fmu: PreparedFMU, rule: str | None = None) -> LatticeObjective:
        """The objective under one diagonal rule (None: the cases decide it)."""
        parameters = dict(self.parameters)
        if rule is not None and rule != self.rule_default:
            parameters["diagonal_rule"] = rule
        return LatticeObjective(
            str(fmu.path),
            self.space,
            self.horizon,
            self.outputs,
            parameters,
            tuple(self.cases),
            self.aggregate,
            self.search_horizon,
            self.search_rtol,
            has_force_limit=fmu.has_force_limit,
            default_rule=rule or self.rule_default,
            fmu_sha256=fmu.sha256,
        )

    def describe(self, fmu: PreparedFMU) -> "CaseDescription":
        objective = self.objective(fmu, self.rules[0] if self.rules else None).describe()
        names = ("load_mode",) + PROJECTILE_PARAMETERS if self.load_mode == PROJECTILE else PULSE_PARAMETERS
        shown = {
            name: self.parameters.get(name, fmu.start(name))
            for name in names + ("load_patch",)
            if name in fmu.parameters
        }
        rule_parameter = fmu.parameters.get("diagonal_rule")
        return CaseDescription(
            scene=self.scene,
            rows=self.rows,
            columns=self.columns,
            space=self.space.describe(),
            design_kind=self.space.kind,
            design_count=self.space.size,
            materials=table_rows(self.materials),
            rules=self.rules,
            objective=objective,
            load=shown,
            parameters=dict(self.parameters),
            cases={k: list(v) for k, v in self.case_lists.items()},
            aggregate=self.aggregate if self.case_lists else None,
            horizon=self.horizon,
            depth=self.depth,
            rule_default=self.rule_default,
            rule_codes=dict(rule_parameter.items) if rule_parameter else {},
        )


def table_rows(table: MaterialTable) -> tuple[dict[str, Any], ...]:
    """The table's rows as results.json states them: each material's properties and the bounds its row gives
    (``k_min``, ``mass_max`` ...: a co-design's factor ranges), so ``MaterialTable.from_rows`` reads back the same
    table."""
    rows = table.rows()
    for row, bounds in zip(rows, table.bounds or ((),) * len(rows)):
        for name, *ends in bounds:
            row.update({f"{name}{suffix}": end for suffix, end in zip(BOUND_SUFFIXES, ends) if end is not None})
    return tuple(rows)


@dataclass(frozen=True)
class CaseDescription:
    """The case as results.json and the report's first screen state it."""

    scene: str
    rows: int
    columns: int
    space: str
    design_kind: str
    design_count: int
    materials: tuple[dict[str, Any], ...]
    rules: tuple[str, ...]
    objective: ObjectiveDescription
    # F_total, load_angle, t_active as the runs use them; under a projectile, load_mode and the projectile's and
    # contact's parameters instead
    load: dict[str, Any]
    parameters: dict[str, Any]
    cases: dict[str, list[Any]]
    aggregate: str | None
    horizon: float
    depth: int = 1
    rule_default: str = ""  # the FMU's own default diagonal rule (what it runs when diagonal_rule is not set)
    rule_codes: dict[str, int] = field(default_factory=dict)  # each diagonal rule's code in the FMU

    def loaded_faces(self) -> tuple[LoadedFace, ...]:
        """The masses of column 1's face the load pushes: under the case's load_patch, or under each of its load
        cases' (--case load_patch=...), in their order."""
        patches = self.cases.get("load_patch") or [self.load.get("load_patch", WHOLE_FACE)]
        return tuple(loaded_face(self.rows, self.depth, int(p)) for p in dict.fromkeys(patches))

    def line(self) -> str:
        """The case in one line: what the first screen and every chart state."""
        load = self.load
        lattice = (
            f"{self.rows} x {self.columns} lattice"
            if self.depth == 1
            else f"{self.rows} x {self.columns} x {self.depth} plate ({self.columns} layers of {self.rows} x "
            f"{self.depth} masses)"
        )
        parts = [lattice, f"{len(self.materials)} materials ({self.design_kind}: {self.design_count:,} designs)"]
        patch = int(load.get("load_patch") or 0)
        spread = (
            f" over a centred {patch} x {patch} patch" if patch else " over the whole face" if self.depth > 1 else ""
        )
        if load.get("load_mode") == PROJECTILE:
            parts.append(
                f"struck{spread} by a {load['projectile_mass']:g} kg projectile at "
                f"{load['projectile_speed']:g} m/s (Hunt-Crossley contact k_c {load['contact_stiffness']:g} "
                f"N/m^{load['contact_exponent']:g}, n {load['contact_exponent']:g}, lambda "
                f"{load['contact_damping']:g} s/m)"
            )
        elif "F_total" in load:
            parts.append(
                f"load {load['F_total']:g} N at {load.get('load_angle', 0):g} deg{spread} for "
                f"{load.get('t_active', 0):g} s"
            )
        parts.append(f"minimising {', '.join(self.objective.outputs)} over {self.horizon:g} s")
        if self.rules:
            parts.append(f"diagonal rule{'s' if len(self.rules) > 1 else ''} {' and '.join(self.rules)}")
        if self.cases:
            parts.append(f"{self.aggregate} of the load cases {self.cases}")
        return ", ".join(parts)


def parse_case_option(text: str) -> tuple[str, list[str]]:
    name, sep, values = text.partition("=")
    name = name.strip()
    items = [v.strip() for v in values.split(",")] if sep else []
    if not name or not sep or not items or any(not v for v in items):
        raise ValueError(
            f"--case {text!r}: expected NAME=V1,V2,... (a scalar parameter of the FMU and a "
            "comma-separated list of values)"
        )
    return name, items


# Parameters a --case may not set: the order is the design, and the searches set their own force limits.
NOT_CASE_PARAMETERS = {
    "peak_force_limit": "the searches set it (their force limits)",
    "repeat_materials": "it is the design space (--repeat)",
}


def resolve_case(config: CaseConfig, resolved: ResolvedScene) -> Case:
    """The case of ``config`` on the scene and FMU ``orchestrator.scene.resolve`` found for it: each value checked
    against the model description."""
    scene, fmu, materials = resolved.scene, resolved.fmu, resolved.table
    if fmu.columns < 2:
        raise ValueError(
            f"{fmu.path.name} has {fmu.columns} column(s) with a material parameter: there is no "
            "material order to search (give a scene with a material per column)"
        )
    parameters: dict[str, Any] = {}
    for name, option_name in SCENE_OPTIONS.items():
        value = getattr(config, SCENE_OPTION_FIELDS[name])
        if value is not None:
            if name not in fmu.parameters:
                raise ValueError(f"{option_name}: {fmu.path.name} has no parameter {name}")
            if name == "load_patch":
                check_load_patch(option_name, scene, value)
            parameters[name] = fmu.parameters[name].convert(value, option_name)
    case_lists: dict[str, tuple[Any, ...]] = {}
    allowed = sorted(n for n in fmu.parameters if n not in NOT_CASE_PARAMETERS)
    for text in config.case:
        name, values = parse_case_option(text)
        if name in NOT_CASE_PARAMETERS:
            raise ValueError(f"--case {name}: not allowed, {NOT_CASE_PARAMETERS[name]}; allowed: {', '.join(allowed)}")
        if name not in fmu.parameters:
            raise ValueError(f"--case {name}: not a scalar parameter of {fmu.path.name}; allowed: {', '.join(allowed)}")
        if name in case_lists:
            raise ValueError(f"--case {name}: given twice; give its values in one list")
        for other, option_name in SCENE_OPTIONS.items():
            if name == other and other in parameters:
                raise ValueError(f"--case {name} and {option_name} both set {name}; give one of them")
        if name == "diagonal_rule" and config.diagonal_rules:
            raise ValueError("--case diagonal_rule and --diagonal-rule both set the diagonal rule; give one of them")
        case_lists[name] = tuple(dict.fromkeys(fmu.parameters[name].convert(v, "--case") for v in values))
    load_mode = check_load_mode(config, fmu, parameters, case_lists)
    rule_parameter = fmu.parameters.get("diagonal_rule")
    rule_names = tuple(rule_parameter.items) if rule_parameter and rule_parameter.items else ()
    rule_default = str(rule_parameter.start) if rule_parameter else ""
    if "diagonal_rule" in case_lists:
        rules: tuple[str, ...] = ()
    elif config.diagonal_rules:
        for rule in config.diagonal_rules:
            if rule not in rule_names:
                raise ValueError(
                    f"--diagonal-rule {rule}: allowed values are {', '.join(rule_names) or 'none'} "
                    f"(the rules {fmu.path.name} declares)"
                )
        rules = tuple(dict.fromkeys(config.diagonal_rules))
    else:
        first = (DESIGN_RULE,) if DESIGN_RULE in rule_names else ()
        rules = tuple(dict.fromkeys(first + (rule_default,) + rule_names)) if rule_names else ()
    horizon = float(config.horizon if config.horizon is not None else scene.horizon)
    if config.repeat and not fmu.has_repeat:
        raise ValueError(f"--repeat: {fmu.path.name} has no repeat_materials parameter (rebuild it)")
    space = DesignSpace(fmu.columns, len(materials), config.repeat)
    from .objective import FMURun, missing_output, output_names

    outputs = output_names(config.objective)
    refusal = missing_output(fmu.path, outputs + FMURun.NEEDS)
    if refusal:
        raise ValueError(f"--objective {refusal}")
    fidelity = search_fidelity_of(config, scene, load_mode, case_lists)
    parameters = {k: v for k, v in parameters.items() if not fmu.is_default(k, v)}
    if config.repeat:
        parameters["repeat_materials"] = 1
    return Case(
        scene=scene.name,
        rows=scene.rows,
        columns=fmu.columns,
        materials=materials,
        space=space,
        departures=resolved.departures,
        outputs=outputs,
        rules=rules,
        rule_default=rule_default,
        parameters=parameters,
        case_lists=case_lists,
        aggregate=config.aggregate or "worst",
        horizon=horizon,
        search_horizon=fidelity.horizon or None,
        search_rtol=fidelity.rtol or None,
        depth=scene.depth,
        load_mode=load_mode,
    )


def check_load_mode(
    config: CaseConfig, fmu: PreparedFMU, parameters: dict[str, Any], case_lists: dict[str, tuple[Any, ...]]
) -> str:
    """The run's load mode (the first case's with --case load_mode=...); refuses input mode (no master sets
    F_front in a search) and options of the other mode's load: a projectile brings its own momentum, so the
    pulse's F_total, load_angle and t_active do nothing under it, and the projectile's parameters nothing under
    the pulse."""
    if "load_mode" not in fmu.parameters:
        return PULSE
    modes = case_lists.get("load_mode") or (parameters.get("load_mode", fmu.start("load_mode")),)
    if INPUT in modes:
        where = "--case load_mode" if "load_mode" in case_lists else f"{fmu.path.name}'s load_mode (its default)"
        raise ValueError(
            f"{where} {INPUT}: input mode needs a co-simulation master to set F_front, which a search "
            f"is not; give --load-mode {PULSE} or {PROJECTILE}"
        )
    how = f"--load-mode {PROJECTILE} or --scene {PROJECTILE_SCENE}"
    for name in PROJECTILE_PARAMETERS if PROJECTILE not in modes else PULSE_PARAMETERS if PULSE not in modes else ():
        option_name = SCENE_OPTIONS.get(name)
        if name in parameters or name in case_lists:
            given_as = option_name if name in parameters else f"--case {name}"
            if name in PROJECTILE_PARAMETERS:
                raise ValueError(f"{given_as}: only under a projectile ({how}); this run's load is the pulse")
            raise ValueError(
                f"{given_as}: the pulse's {name} does nothing under a projectile (it brings its own "
                f"momentum); give {', '.join(SCENE_OPTIONS[p] for p in PROJECTILE_PARAMETERS)}"
            )
    return modes[0]


def search_fidelity_of(
    config: CaseConfig, scene, load_mode: str, case_lists: dict[str, tuple[Any, ...]]
) -> SearchFidelity:
    """The searches' horizon and tolerance (0: the full horizon, the FMU's tolerance): the ones given, else the
    load mode's (the longest horizon and the tightest tolerance of the load cases' modes)."""
    modes = [search_fidelity(mode, scene) for mode in (case_lists.get("load_mode") or (load_mode,))]
    return SearchFidelity(
        config.search_horizon if config.search_horizon is not None else max(m.horizon for m in modes),
        config.search_rtol if config.search_rtol is not None else min(m.rtol for m in modes),
    )


# ---------------------------------------------------------------------------------------------- steps
@dataclass(frozen=True)
class NoOptions:
    """A step without options of its own."""


@dataclass(frozen=True)
class Verdict:
    """A step's word on the study's answer (``Step.verdict``): it holds the answer (the steps after it are not
    asked), it refuses one (``refusal``: why the study has no usable answer), or it has nothing to say."""

    answered: bool = False
    refusal: str | None = None

    @classmethod
    def answer(cls) -> "Verdict":
        return cls(answered=True)

    @classmethod
    def no_answer(cls, why: str) -> "Verdict":
        return cls(refusal=why)


SILENT = Verdict()


class Step:
    """One feature of a study. Subclasses set ``name`` (its key in results.json and the study file), ``title``
    (its report section), ``template`` (its report template, None: not shown), ``Config`` and implement
    ``run``."""

    name: ClassVar[str]
    title: ClassVar[str]
    template: ClassVar[str | None] = None
    chart_file: ClassVar[str | None] = None  # the file of its chart, when it has one
    Config: ClassVar[type] = NoOptions

    def __init__(self, config=None):
        self.config = config if config is not None else self.Config()

    def applies(self, context: "StudyContext") -> bool:
        return True

    def replaces(self, context: "StudyContext") -> tuple[type, ...]:
        """The steps this one does the work of in this run (they do not run)."""
        return ()

    def check(self, context: "StudyContext") -> None:
        """Refuses, before any simulation, options of this step that mean nothing in this run."""

    def run(self, context: "StudyContext") -> Any:
        raise NotImplementedError

    def chart(self, study: "StudyResult", path) -> str | None:
        """The step's chart, a PNG at ``path`` drawn from the study's results (its file name); None: none."""
        return None

    def design_files(self, study: "StudyResult") -> list[tuple[str, tuple[int, ...], str]]:
        """(file name, design, diagonal rule) of each design file the report writes for this step."""
        return []

    def design_parameters(self, study: "StudyResult") -> dict[str, dict[str, float]]:
        """The material properties (FMU parameters ``k[3]`` ...) each of ``design_files`` sets away from the
        table, by file name: a co-design's layers."""
        return {}

    def verdict(self, result: Any, study: "StudyResult") -> Verdict:
        """What this step's ``result`` (None: the step did not run) says of the study's answer."""
        return SILENT

    def cost_note(self, context: "StudyContext") -> str:
        """Why this step simulates what it does, once it ran, and the option that bounds it (the console says
        it when the step simulates more than the searches)."""
        return ""


@dataclass
class StudyContext:
    """What a step sees: the FMU, the case, the one evaluator, the earlier steps' results."""

    fmu: PreparedFMU
    case: Case
    evaluator: Evaluator
    steps: list[Step]
    progress: Progress = field(default_factory=Progress)
    executor_kind: str = "serial"
    confirm_cost: bool = False  # work beyond a stated bound was confirmed (--confirm-cost)
    beyond_bounds: list[str] = field(default_factory=list)  # what in this run is beyond a stated bound
    results: dict[type[Step], Any] = field(default_factory=dict)
    _objectives: dict = field(default_factory=dict)

    def objective(self, rule: str | None) -> LatticeObjective:
        if rule not in self._objectives:
            self._objectives[rule] = self.case.objective(self.fmu, rule)
        return self._objectives[rule]

    @property
    def rules(self) -> tuple[str | None, ...]:
        """The rules searched; (None,) when the load cases set the rule."""
        return self.case.rules or (None,)

    def result(self, step_type: type) -> Any:
        """The result of the step of that type, or None when it did not run."""
        return self.results.get(step_type)

    def config(self, step_type: type[Step]):
        step = next((s for s in self.steps if isinstance(s, step_type)), None)
        return step.config if step is not None else step_type.Config()

    def options(self, config_type: type):
        """The options of type ``config_type`` this run was given (its defaults when no step takes them): what a
        step reads of a later step's options without importing that step."""
        return next((s.config for s in self.steps if isinstance(s.config, config_type)), config_type())

    def given(self, step_type: type) -> frozenset[str]:
        return given(self.config(step_type))


@dataclass(frozen=True)
class StepCost:
    """What one step simulated: the evaluator's tasks (an FMU run each; a sweep's chunk is one), and why."""

    step: str  # the step's name
    title: str
    simulated: int
    note: str


@dataclass(frozen=True)
class StudyResult:
    """What a study found: the case, each step's result by its step's type, and how it was computed."""

    case: CaseDescription
    fmu_path: str
    fmu_sha256: str
    results: dict[type[Step], Any]  # step class -> its result, in the order the steps ran
    evaluator: EvaluatorState
    wall_seconds: float
    run_id: str
    costs: tuple[StepCost, ...] = ()  # each step that ran, in order

    def result(self, step_type: type) -> Any:
        """The result of the step of that type, or None when it did not run."""
        return self.results.get(step_type)

    def failure_summary(self) -> str:
        """How many evaluations failed and the most common cause, in one line (the console's; the report and
        evaluations.csv give every one)."""
        state = self.evaluator
        if not state.failed:
            return "no evaluation ran"
        cause, count = state.failure_causes[0]
        return (
            f"{state.failed:,} evaluation{'s' if state.failed > 1 else ''} failed; "
            f"{'every one' if count == state.failed else f'{count:,} of them'}: {cause}"
        )

    def results_by_name(self) -> dict[str, Any]:
        """Each result under its step's name: the keys of results.json's ``steps``, and nothing else."""
        return {step_type.name: result for step_type, result in self.results.items()}


def run_study(context: StudyContext, run_id: str = "") -> StudyResult:
    """Every step that applies, in order."""
    start = time.perf_counter()
    results = {}
    costs = []
    replaced = {other for step in context.steps for other in step.replaces(context)}
    for step in context.steps:
        if type(step) in replaced or not step.applies(context):
            continue
        raise_if_requested()
        simulated = context.evaluator.state().simulated
        result = step.run(context)
        context.results[type(step)] = result
        results[type(step)] = result
        costs.append(
            StepCost(step.name, step.title, context.evaluator.state().simulated - simulated, step.cost_note(context))
        )
    return StudyResult(
        context.case.describe(context.fmu),
        str(context.fmu.path),
        context.fmu.sha256,
        results,
        context.evaluator.state(),
        time.perf_counter() - start,
        run_id,
        tuple(costs),
    )


__all__ = [
    "Case",
    "CaseConfig",
    "CaseDescription",
    "DESIGN_RULE",
    "INPUT",
    "LOAD_MODES",
    "MAX_HORIZON",
    "MAX_RUNS_PER_DESIGN",
    "NoOptions",
    "PROJECTILE",
    "PULSE",
    "SILENT",
    "Step",
    "StepCost",
    "StudyContext",
    "StudyResult",
    "SearchFidelity",
    "Verdict",
    "resolve_case",
    "run_study",
    "search_fidelity",
    "table_rows",
]
