"""The scenes: what one FMU models (lattice size, parameter values, which parameters it exposes, horizon).

One module for build_fmu.py (which compiles a scene into an FMU), the orchestrator (which runs one) and the
reference model (`reference.Scene.from_description`). The study's scenes are the JSON files beside this
module (package data: they are installed with it); `Scene.load` takes one of their names or a path to any
scene's .json file.

Names and model identifiers must be identifiers (`[A-Za-z_][A-Za-z0-9_]*`): a model identifier names the
FMU's binary and its file (`models/<identifier>.fmu`), and a scene name a file in this folder, so neither
may carry a path.
"""

from __future__ import annotations

import json
import os
import re
from dataclasses import dataclass, field, replace
from functools import lru_cache
from pathlib import Path

from fmu_src.core import MAX_COLS
from fmu_src.materials import MaterialTable, load_materials
from fmu_src.variables import Interface, all_variables, make_interface, with_node_mass

SCENE_DIR = Path(__file__).resolve().parent
DEFAULT_SCENE = "armour_11x11"
PROJECTILE_SCENE = "projectile_11x11"  # the armour scene struck by the default projectile (docs/model.md 11)
IDENTIFIER = re.compile(r"[A-Za-z_][A-Za-z0-9_]*")
# The tool name under which a model description declares its lattice's size (rows, columns, depth): FMI 2's
# <VendorAnnotations><Tool>, FMI 3's <Annotations><Annotation type>.
SIZE_ANNOTATION = "mass-spring-lattice"
IDENTIFIER_RULE = "a letter or underscore, then letters, digits or underscores ([A-Za-z_][A-Za-z0-9_]*)"


def check_identifier(key: str, value) -> str:
    """The value when it is a safe identifier, else a one-line ValueError naming the key and the rule."""
    if not isinstance(value, str) or not IDENTIFIER.fullmatch(value):
        raise ValueError(f"scene {key} {value!r} is not allowed: it must be {IDENTIFIER_RULE}")
    return value


def scene_names() -> list[str]:
    """The scenes shipped with the package."""
    return sorted(p.stem for p in SCENE_DIR.glob("*.json"))


@dataclass
class Scene:
    """A named scene: lattice size (rows x cols, and the depth along z: docs/model.md section 10), parameter values,
    which parameters the FMU exposes, the horizon."""

    name: str
    model_identifier: str = "MassSpringLattice"
    description: str = ""
    rows: int = 11
    cols: int = 11
    depth: int = 1
    parameters: dict = field(default_factory=dict)
    hidden: list = field(default_factory=list)
    horizon: float = 8.0
    communication_step: float = 0.01
    # the horizon (s) and the solver tolerance of the searches' cheaper evaluation (None: the study's pulse's,
    # orchestrator.objective.SEARCH_HORIZON and SEARCH_RTOL), for a scene whose load lasts longer than the pulse
    # or whose good designs lie closer together
    search_horizon: float | None = None
    search_rtol: float | None = None
    # the material table: a list of rows (name, k, k_diag, c, alpha, alpha_diag), the path of a table file
    # (.csv, .toml, .json; relative to the scene file), a MaterialTable, or None for the study's
    materials: str | list | MaterialTable | None = None

    def __post_init__(self):
        check_identifier("name", self.name)
        check_identifier("model_identifier", self.model_identifier)
        for key, high in (("rows", None), ("cols", MAX_COLS), ("depth", None)):
            value = getattr(self, key)
            if isinstance(value, bool) or not isinstance(value, int) or value < 1 or (high and value > high):
                allowed = f"an integer from 1 to {high}" if high else "an integer of at least 1"
                raise ValueError(f"scene {self.name}: {key} must be {allowed}, got {value!r}")
        if self.search_horizon is not None and (
            isinstance(self.search_horizon, bool)
            or not isinstance(self.search_horizon, (int, float))
            or not 0 < self.search_horizon <= self.horizon
        ):
            raise ValueError(
                f"scene {self.name}: search_horizon must be a number of seconds in (0, horizon = "
                f"{self.horizon:g}], got {self.search_horizon!r}"
            )
        if self.search_rtol is not None and (
            isinstance(self.search_rtol, bool)
            or not isinstance(self.search_rtol, (int, float))
            or not 0 < self.search_rtol < 1
        ):
            raise ValueError(f"scene {self.name}: search_rtol must be a number in (0, 1), got {self.search_rtol!r}")

    def material_table(self) -> MaterialTable | None:
        """The scene's material table (checked row by row), or None for the study's."""
        if self.materials is None or isinstance(self.materials, MaterialTable):
            return self.materials
        if isinstance(self.materials, (str, os.PathLike)):
            return load_materials(self.materials)
        if isinstance(self.materials, list):
            return MaterialTable.from_rows(self.materials, f"scene {self.name}: materials")
        raise ValueError(
            f"scene {self.name}: materials must be a list of rows or the path of a table file, got "
            f"{type(self.materials).__name__}"
        )

    @classmethod
    def load(cls, name_or_path: str | os.PathLike) -> "Scene":
        """A scene by name (a file of this folder) or by the path of its .json file."""
        text = str(name_or_path)
        if text.endswith(".json"):
            path = Path(text)
        else:
            if not IDENTIFIER.fullmatch(text):
                raise ValueError(
                    f"scene {text!r} is not allowed: give one of {scene_names()} or a path to a .json file"
                )
            path = SCENE_DIR / f"{text}.json"
        if not path.is_file():
            raise ValueError(f"scene {text!r} not found: give one of {scene_names()} or a path to a .json file")
        try:
            data = json.loads(path.read_text())
        except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
            raise ValueError(f"scene {path}: not a readable JSON file ({exc})") from None
        if not isinstance(data, dict):
            raise ValueError(f"scene {path}: expected a JSON object of scene keys")
        allowed = set(cls.__dataclass_fields__)
        unknown = set(data) - allowed
        if unknown:
            raise ValueError(f"scene {path}: unknown keys {sorted(unknown)}; allowed: {sorted(allowed)}")
        if "name" not in data:
            raise ValueError(f"scene {path}: the key 'name' is missing")
        if isinstance(data.get("materials"), str):  # a table file beside the scene file
            data["materials"] = str((path.parent / data["materials"]).resolve())
        return cls(**data)

    def interface(self) -> Interface:
        """The FMU's variables for this scene: exposed ones with value references, hidden ones compiled in."""
        return make_interface(
            self.rows, self.cols, self.parameters, tuple(self.hidden), self.material_table(), self.depth
        )

    def parameter_values(self) -> dict:
        """Every parameter's value in this scene (the scene's own, else the FMU's default), by FMU name;
        arrays as tuples."""
        values = {}
        parameters, table = with_node_mass(self.parameters, self.material_table(), self.cols)
        for variable in all_variables(self.rows, self.cols, table, self.depth):
            if variable.causality != "parameter":
                continue
            value = parameters.get(variable.name, variable.start)
            values[variable.name] = tuple(value) if isinstance(value, (list, tuple)) else value
        return values

    def size(self) -> tuple[int, int, int]:
        """(rows, columns, depth): what an FMU of this scene declares as its lattice's size."""
        return self.rows, self.cols, self.depth


def resolve_scene(
    scene: Scene | str | None = None,
    rows: int | None = None,
    cols: int | None = None,
    materials: MaterialTable | str | os.PathLike | None = None,
    depth: int | None = None,
    load_patch: int | None = None,
    own_identifier: bool = True,
) -> Scene:
    """The scene an FMU is built and run for: a Scene, a scene name or path (default: the study's), with rows,
    cols or depth overridden (a resized scene keeps its scalar parameters only), load_patch as the start of that
    parameter, and `materials` (a MaterialTable or the path of a table file) as its material table. With
    `own_identifier`, a scene changed here gets its own model identifier, naming the size, the patch and the
    table's fingerprint that differ from the scene's, so that the FMUs of two variants never share a file."""
    if not isinstance(scene, Scene):
        scene = Scene.load(scene or DEFAULT_SCENE)
    resized = scene
    if rows is not None or cols is not None or depth is not None:
        resized = replace(
            scene,
            rows=rows or scene.rows,
            cols=cols or scene.cols,
            depth=depth or scene.depth,
            parameters={k: v for k, v in scene.parameters.items() if not isinstance(v, (list, tuple))},
        )
    if load_patch is not None:
        resized = replace(resized, parameters={**resized.parameters, "load_patch": load_patch})
    if materials is not None:
        table = materials if isinstance(materials, MaterialTable) else load_materials(materials)
        resized = replace(resized, materials=table)
    if own_identifier and resized != scene:
        identifier = scene.model_identifier
        if resized.size() != scene.size():
            identifier += f"{resized.rows}x{resized.cols}" + (f"x{resized.depth}" if resized.depth > 1 else "")
        if resized.parameters.get("load_patch") != scene.parameters.get("load_patch"):
            identifier += f"_patch{load_patch}"
        if materials is not None:
            identifier += f"_{table.sha256()[:8]}"
        resized = replace(resized, model_identifier=identifier)
    return resized


@lru_cache(maxsize=1)
def _study_scene() -> Scene:
    return Scene.load(DEFAULT_SCENE)


def study_parameter_values() -> dict:
    """Every parameter's value in the study's own scene: what the study's published numbers and known optima
    hold for."""
    return dict(_study_scene().parameter_values())


def is_study_scene(scene: Scene) -> bool:
    """Whether ``scene`` (resolved: size, patch and table applied) is the study's own, the one its published
    results and known optima hold for."""
    return scene == _study_scene()


__all__ = [
    "DEFAULT_SCENE",
    "IDENTIFIER",
    "PROJECTILE_SCENE",
    "SCENE_DIR",
    "SIZE_ANNOTATION",
    "Scene",
    "check_identifier",
    "is_study_scene",
    "resolve_scene",
    "scene_names",
    "study_parameter_values",
]
