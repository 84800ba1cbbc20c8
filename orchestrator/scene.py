"""The one owner of a run's scene: the case's options resolved once into the scene, its material table and its
FMU, and how far that FMU departs from the study's own scene (``scenes.is_study_scene`` says it of a scene).

The command line, the runner, the study's ``resolve_case`` and the benchmarks ask ``resolve``; the scene's size,
patch and table are applied by ``scenes.resolve_scene`` (which the builder asks too), and an FMU given on its
own is checked against the scene by the size its model description declares (``orchestrator.fmu``). A new
scene is a JSON file in ``scenes/``; nothing here changes for it.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

from fmu_src.materials import STUDY_MATERIAL_COUNT, MaterialTable, load_materials, study_materials
from fmu_src.variables import load_patch_allowed, load_patch_refusal
from scenes import Scene, study_parameter_values
from scenes import resolve_scene as resized_scene

from .fmu import PreparedFMU, prepare_fmu

if TYPE_CHECKING:
    from .study import CaseConfig


@dataclass(frozen=True)
class ResolvedScene:
    """A case's scene resolved once: the scene (size, depth, patch and table applied), the material table the
    designs draw from, the FMU that runs it, and the FMU's parameters that depart from the study's scene."""

    scene: Scene
    table: MaterialTable
    fmu: PreparedFMU
    departures: tuple[str, ...]  # the FMU's defaults that are not the study's scene's (see departures_from_the_study)


def resolve(case: "CaseConfig") -> ResolvedScene:
    """The scene, table and FMU of ``case``, each checked once, before any simulation."""
    materials = load_materials(case.materials) if case.materials else None
    scene = resolve_scene(case, materials)
    fmu = prepare_fmu(scene, case.fmu)
    if materials is not None and len(materials) != fmu.materials:
        raise ValueError(
            f"--materials {case.materials}: {len(materials)} materials, but {fmu.path.name} has a "
            f"table of {fmu.materials}"
        )
    if materials is None and scene.material_table() is None and fmu.materials > STUDY_MATERIAL_COUNT:
        raise ValueError(
            f"{fmu.path.name} has a table of {fmu.materials} materials, the study's has "
            f"{STUDY_MATERIAL_COUNT}: give the FMU's own table with --materials FILE"
        )
    table = materials or scene.material_table() or study_materials(fmu.materials)
    return ResolvedScene(scene, table, fmu, departures_from_the_study(fmu))


def resolve_scene(case: "CaseConfig", materials: MaterialTable | None) -> Scene:
    """The scene to run: the named one, with the lattice's columns, depth and the material table given; refused
    when the table has fewer materials than columns and a material may fill only one (no material is
    invented)."""
    scene = Scene.load(case.scene)
    check_table_size(case, scene, materials)
    if case.cols is not None or case.depth is not None or materials is not None:
        scene = resized_scene(scene, cols=case.cols, materials=materials, depth=case.depth)
    return scene


def narrowed_table_note(case: "CaseConfig") -> str | None:
    """The one-line note for --cols C below the study's eleven materials without a table of the user's: the
    lattice takes the study's first C materials, as its narrower lattices and their known optima do, not C of
    the eleven as a table of M would give; None when that is not the case."""
    from .design import DesignSpace

    if (
        case.cols is None
        or case.materials
        or case.fmu
        or case.cols >= STUDY_MATERIAL_COUNT
        or Scene.load(case.scene).material_table() is not None
    ):
        return None
    columns = case.cols
    own = DesignSpace(columns, columns, case.repeat).size
    chosen = DesignSpace(columns, STUDY_MATERIAL_COUNT, case.repeat).size
    return (
        f"note: --cols {columns} without --materials takes the first {columns} of the study's "
        f"{STUDY_MATERIAL_COUNT} materials (m1..m{columns}: {own:,} designs), as the study's narrower lattices and "
        f"their known optima do; to choose {columns} of the {STUDY_MATERIAL_COUNT} ({chosen:,} designs), give "
        "the study's table as --materials FILE (its values: docs/model.md section 3)"
    )


def check_table_size(case: "CaseConfig", scene: Scene, materials: MaterialTable | None) -> None:
    """More columns than the table has materials, each used at most once, is refused in one line (before any
    build): the FMU would otherwise need materials that are in no table."""
    if case.repeat or scene.parameters.get("repeat_materials"):
        return
    columns = case.cols or scene.cols
    if materials is not None:
        count, table = len(materials), f"--materials {case.materials} has"
    else:
        own = scene.material_table()
        count = len(own) if own is not None else STUDY_MATERIAL_COUNT
        table = f"scene {scene.name}'s table has" if own is not None else "the study's table has"
    if columns > count:
        flag = f"--cols {columns}" if case.cols else f"scene {scene.name} ({columns} columns)"
        raise ValueError(
            f"{flag}: {table} {count} materials and each fills at most one column; give --cols 2.."
            f"{count}, --repeat (a material may fill several columns) or --materials FILE with at "
            f"least {columns} materials"
        )


def check_load_patch(option_name: str, scene: Scene, value: int) -> None:
    """A load patch the scene's face cannot hold is refused in one line (the core's rule,
    ``fmu_src.variables.load_patch_allowed``)."""
    if not load_patch_allowed(scene.rows, scene.depth, value):
        raise ValueError(f"{option_name} {value}: {load_patch_refusal(scene.rows, scene.depth, value)}")


def departures_from_the_study(fmu: PreparedFMU) -> tuple[str, ...]:
    """The FMU's scalar parameters whose defaults are not those of the study's own scene, the diagonal rule
    aside (each rule is a case of its own): whatever a known optimum of the study says, it was not found for
    such an FMU."""
    study = study_parameter_values()
    departures = []
    for name, parameter in fmu.parameters.items():
        value = study.get(name)
        if name == "diagonal_rule" or isinstance(value, (list, tuple)):
            continue
        try:
            same = value is not None and parameter.value(parameter.start) == parameter.value(value)
        except ValueError:
            same = False
        if not same:
            departures.append(name)
    return tuple(departures)


__all__ = [
    "ResolvedScene",
    "check_load_patch",
    "check_table_size",
    "departures_from_the_study",
    "narrowed_table_note",
    "resolve",
    "resolve_scene",
]
