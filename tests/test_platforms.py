"""The FMU for every platform we can build (build_fmu.py --platforms), and its proof in an importer we did not write.

The default suite checks what the build writes: each platform's library of its architecture (read from its
ELF/PE header), under the folder its FMI version names, FMPy's validate clean, the refusals in one line. It
skips, saying which package is missing, where the cross compilers are not installed.

The opt-in group (`platforms`) runs the FMU in the Reference FMUs' fmusim (the C program of Reference-FMUs
v0.0.39, built for each platform from its sources with zlib, libxml2 and SUNDIALS CVODE) on x86_64-linux, under
Wine (x86_64-windows) and under qemu-user (aarch64-linux), FMI 2 and 3, Co-Simulation and Model Exchange:

    FMUSIM_X86_64_LINUX=.../fmusim FMUSIM_X86_64_WINDOWS=.../fmusim.exe FMUSIM_AARCH64_LINUX=.../fmusim \\
        python -m pytest -m platforms tests/test_platforms.py

needs `wine` and `qemu-aarch64` on PATH (Debian: wine64, qemu-user) and the aarch64 C library for qemu
(QEMU_LD_PREFIX, default /usr/aarch64-linux-gnu, from the cross compiler's packages). Each run writes its row of
the compatibility page (tests/compatibility.py, under --record-compatibility).
"""

from __future__ import annotations

import csv
import os
import shlex
import shutil
import subprocess
import zipfile

import pytest

from builder import build
from builder.platforms import ALL_PLATFORMS, PLATFORMS, compiler_for, header_machine, native_platform, parse_platforms
from fmu_src.published import PUBLISHED_PEAKS, SEQUENTIAL_ORDER, STUDY_BEST_ORDER
from compatibility import compatibility_row

ORDERS = (SEQUENTIAL_ORDER, STUDY_BEST_ORDER)
FMUSIM_VARIABLES = {
    "x86_64-linux": "FMUSIM_X86_64_LINUX",
    "x86_64-windows": "FMUSIM_X86_64_WINDOWS",
    "aarch64-linux": "FMUSIM_AARCH64_LINUX",
}
# The program that runs another platform's executable here, and its Debian package.
EMULATORS = {"x86_64-windows": ("wine", "wine64"), "aarch64-linux": ("qemu-aarch64", "qemu-user")}
PUBLISHED_ACCURACY = 1e-6
SAME_AS_NATIVE = 1e-12
# fmusim's Model Exchange: its CVODE at this relative tolerance (absolute: the states' nominals times it) on the
# default experiment's 0.01 s output grid, the tolerance the project's own Model Exchange tests give fmpy.
ME_TOLERANCE = 1e-9
INTERFACES = {"cs": "CS", "me": "ME"}


def _missing_compilers(names) -> str | None:
    for name in names:
        try:
            compiler_for(PLATFORMS[name])
        except RuntimeError as exc:
            return str(exc)
    return None


def _binaries(fmu) -> dict[str, tuple[str, str]]:
    """binaries/<folder>/<file> -> (format, architecture) read from each library's header in the FMU."""
    with zipfile.ZipFile(fmu) as archive:
        return {
            name: header_machine(archive.read(name), name)
            for name in archive.namelist()
            if name.startswith("binaries/") and not name.endswith("/")
        }


@pytest.fixture(scope="session")
def platform_fmus(tmp_path_factory):
    """The FMUs the platform tests load, built once per session: FMI 3 with all three platforms, FMI 2 with
    x86_64-linux and x86_64-windows (`all`), FMI 2 with aarch64-linux alone (it shares linux64)."""
    folder = tmp_path_factory.mktemp("platform_fmus")
    built = {}

    def fmu(fmi_version: int, platform: str):
        platforms = "aarch64-linux" if (fmi_version, platform) == (2, "aarch64-linux") else "all"
        key = (fmi_version, platforms)
        if key not in built:
            missing = _missing_compilers(n for n in (ALL_PLATFORMS[fmi_version] if platforms == "all" else [platforms]))
            if missing:
                pytest.skip(missing)
            name = f"MassSpringLattice-fmi{fmi_version}-{platforms}.fmu"
            built[key] = build.build_fmu(
                output=folder / name, werror=True, fmi_version=fmi_version, platforms=platforms
            )
        return built[key]

    return fmu


# ------------------------------------------------------------------ the build (default suite)


@pytest.mark.parametrize("fmi_version", [2, 3])
def test_all_platforms_put_each_library_of_its_architecture_in_its_folder(platform_fmus, fmi_version):
    from fmpy.validation import validate_fmu

    fmu = platform_fmus(fmi_version, "x86_64-linux")
    expected = {
        f"binaries/{PLATFORMS[name].folder(fmi_version)}/MassSpringLattice{PLATFORMS[name].suffix}": (
            "PE" if PLATFORMS[name].suffix == ".dll" else "ELF",
            PLATFORMS[name].machine,
        )
        for name in ALL_PLATFORMS[fmi_version]
    }
    assert _binaries(fmu) == expected
    assert validate_fmu(str(fmu)) == []
    if fmi_version == 2:
        aarch64 = platform_fmus(2, "aarch64-linux")
        assert _binaries(aarch64) == {"binaries/linux64/MassSpringLattice.so": ("ELF", "aarch64")}
        assert validate_fmu(str(aarch64)) == []


# The tool that lists a library's exported functions, by platform: (program, its arguments).
EXPORT_LISTERS = {
    "x86_64-linux": ("nm", ["-D", "--defined-only"]),
    "aarch64-linux": ("aarch64-linux-gnu-nm", ["-D", "--defined-only"]),
    "x86_64-windows": ("x86_64-w64-mingw32-objdump", ["-p"]),
}


def _exported(library, platform: str, prefix: str) -> set[str]:
    """The functions named `prefix`... that `library` exports: its dynamic symbols (ELF) or its export table (PE)."""
    program, arguments = EXPORT_LISTERS[platform]
    if shutil.which(program) is None:
        pytest.skip(f"{program} is not installed (binutils for {platform})")
    listing = subprocess.run([program, *arguments, str(library)], capture_output=True, text=True, check=True).stdout
    if platform == "x86_64-windows":
        listing = listing.split("[Ordinal/Name Pointer] Table", 1)[1]
    return {word for line in listing.splitlines() for word in line.split()[-1:] if word.startswith(prefix)}


@pytest.mark.parametrize("fmi_version", [2, 3])
def test_every_platforms_library_exports_what_the_fmi_header_declares(platform_fmus, fmi_version, tmp_path):
    """The glue's functions, the refused ones written from fmu_src/common/refused_calls.h included, on each
    platform: an importer may look up any function the FMI header declares."""
    from test_refused_calls import declared_functions

    fmu = platform_fmus(fmi_version, "x86_64-linux")
    folders = {PLATFORMS[name].folder(fmi_version): name for name in ALL_PLATFORMS[fmi_version]}
    with zipfile.ZipFile(fmu) as archive:
        libraries = [name for name in archive.namelist() if name.startswith("binaries/") and not name.endswith("/")]
        assert len(libraries) == len(folders)
        for name in libraries:
            platform = folders[name.split("/")[1]]
            library = archive.extract(name, tmp_path)
            exported = _exported(library, platform, f"fmi{fmi_version}")
            assert exported == declared_functions(fmi_version), platform


def test_the_windows_library_needs_only_what_windows_has(platform_fmus, tmp_path):
    """No libgcc_s_seh-1.dll or libwinpthread-1.dll beside it: an importer loads it as it is."""
    objdump = shutil.which("x86_64-w64-mingw32-objdump")
    if objdump is None:
        pytest.skip("x86_64-w64-mingw32-objdump is not installed: apt-get install binutils-mingw-w64-x86-64")
    with zipfile.ZipFile(platform_fmus(3, "x86_64-windows")) as archive:
        archive.extract("binaries/x86_64-windows/MassSpringLattice.dll", tmp_path)
    headers = subprocess.run(
        [objdump, "-p", str(tmp_path / "binaries/x86_64-windows/MassSpringLattice.dll")],
        capture_output=True,
        text=True,
        check=True,
    ).stdout
    imported = {line.split(":", 1)[1].strip().lower() for line in headers.splitlines() if "DLL Name:" in line}
    assert imported <= {"kernel32.dll", "msvcrt.dll"}, imported
    exported = headers.split("[Ordinal/Name Pointer] Table", 1)[1]
    assert "fmi3InstantiateCoSimulation" in exported and "fmi3DoStep" in exported


def test_the_platforms_are_refused_in_one_line_naming_the_allowed_values():
    with pytest.raises(
        ValueError, match="allowed values are 'all' or a comma list of x86_64-linux, x86_64-windows, aarch64-linux"
    ):
        parse_platforms("x86_64-linux,sparc-solaris", 3)
    with pytest.raises(ValueError, match="FMI 2 has one folder, binaries/linux64, for x86_64-linux and aarch64-linux"):
        parse_platforms("x86_64-linux,aarch64-linux", 2)
    assert [p.name for p in parse_platforms("all", 2)] == ["x86_64-linux", "x86_64-windows"]
    assert [p.name for p in parse_platforms(" aarch64-linux, x86_64-linux ,aarch64-linux", 3)] == [
        "aarch64-linux",
        "x86_64-linux",
    ]


def test_a_missing_cross_compiler_is_refused_naming_its_package(monkeypatch, tmp_path, capsys):
    import build_fmu

    monkeypatch.setenv("CC_X86_64_WINDOWS", "no-such-mingw-gcc")
    assert build_fmu.main(["--platforms", "x86_64-windows", "-o", str(tmp_path / "x.fmu")]) == 2
    error = capsys.readouterr().err.strip()
    assert error.count("\n") == 0
    assert "platform x86_64-windows needs the C compiler no-such-mingw-gcc" in error
    assert "apt-get install gcc-mingw-w64-x86-64" in error and "CC_X86_64_WINDOWS" in error
    assert not (tmp_path / "x.fmu").exists()
    assert build_fmu.main(["--platforms", "x86_64-linux,aarch64-linux", "-o", str(tmp_path / "y.fmu")]) == 2
    assert "use --fmi-version 3" in capsys.readouterr().err


def test_the_object_cache_keys_on_the_compiler_and_its_target(tmp_path):
    """An object compiled by the cross compiler is never taken for the native one's (same flags, same source)."""
    missing = _missing_compilers(["aarch64-linux"])
    if missing:
        pytest.skip(missing)
    native = native_platform() or "x86_64-linux"
    source = build.DEFAULT_MODEL_DIR / "solver.c"
    (tmp_path / build.TABLE_HEADER).write_text(build.generate_table_header())
    flags = ["-std=c99", "-O3", f"-I{build.DEFAULT_MODEL_DIR}", f"-I{tmp_path}"]
    keys = {build.object_key(flags, source, compiler_for(PLATFORMS[name])) for name in (native, "aarch64-linux")}
    assert len(keys) == 2
    assert "aarch64" in build.compiler_version(tuple(compiler_for(PLATFORMS["aarch64-linux"])))


# ------------------------------------------------------------------ fmusim on each platform (opt-in)


def _fmusim(platform: str) -> list[str]:
    """The command that runs this platform's fmusim here: the executable from its variable, under its emulator."""
    variable = FMUSIM_VARIABLES[platform]
    executable = os.environ.get(variable)
    if not executable:
        pytest.skip(f"{variable} is not set: the path of the Reference FMUs' fmusim built for {platform}")
    if not os.path.isfile(executable):
        pytest.fail(f"{variable}={executable}: no such file")
    if platform == native_platform() or platform not in EMULATORS:
        return [executable]
    emulator, package = EMULATORS[platform]
    if shutil.which(emulator) is None:
        pytest.skip(f"{emulator} is not installed: apt-get install {package}")
    return [emulator, executable]


def _environment() -> dict[str, str]:
    env = dict(os.environ)
    env.setdefault("QEMU_LD_PREFIX", "/usr/aarch64-linux-gnu")
    env.setdefault("WINEDEBUG", "-all")
    return env


def order_options(order, fmi_version: int) -> list[str]:
    """fmusim's start values of the order: FMI 2's scalars material[j], FMI 3's array material (its values
    space-separated)."""
    if fmi_version == 3:
        return ["--start-value", "material", " ".join(str(material) for material in order)] if order else []
    options = []
    for index, material in enumerate(order, start=1):
        options += ["--start-value", f"material[{index}]", str(material)]
    return options


def fmusim_options(interface: str, order, fmi_version: int) -> list[str]:
    options = ["--interface-type", interface, "--output-variable", "peak_backplate_force"]
    if interface == "me":
        options += ["--solver", "cvode", "--tolerance", repr(ME_TOLERANCE)]
    return options + order_options(order, fmi_version)


def run_fmusim(command: list[str], fmu, interface: str, order, out_dir, fmi_version: int) -> float:
    """The FMU's final peak_backplate_force in one fmusim run (the last row of its output CSV)."""
    output = out_dir / f"{interface}_{''.join(f'{m:x}' for m in order)}.csv"
    done = subprocess.run(
        [*command, *fmusim_options(interface, order, fmi_version), "--output-file", str(output), str(fmu)],
        capture_output=True,
        text=True,
        env=_environment(),
        timeout=1800,
    )
    if done.returncode != 0 or not output.is_file():
        problem = (done.stderr.strip() or done.stdout.strip() or "no output").splitlines()[-1]
        raise AssertionError(f"fmusim exited with {done.returncode}: {problem}")
    with open(output, newline="") as handle:
        rows = list(csv.DictReader(handle))
    if float(rows[-1]["time"]) != 8.0:
        raise AssertionError(f"fmusim stopped at t = {rows[-1]['time']} s, not 8 s")
    return float(rows[-1]["peak_backplate_force"])


def _version(command: list[str]) -> str:
    """fmusim's own version ("fmusim v0.0.39 (x86_64-windows)" -> "0.0.39")."""
    done = subprocess.run([*command, "--version"], capture_output=True, text=True, env=_environment(), timeout=300)
    words = done.stdout.split()
    return words[1].lstrip("v") if len(words) > 1 else "unknown"


def _emulator_note(platform: str) -> str:
    if platform not in EMULATORS or platform == native_platform():
        return "native"
    emulator = EMULATORS[platform][0]
    done = subprocess.run([emulator, "--version"], capture_output=True, text=True, env=_environment(), timeout=300)
    return f"under {(done.stdout.strip().splitlines() or [emulator])[0]}"


@pytest.fixture(scope="session")
def native_peaks(platform_fmus, tmp_path_factory):
    """The peaks fmusim gets from the x86_64-linux library of the same FMU: what every platform must equal."""
    peaks = {}

    def get(fmi_version: int, interface: str) -> dict:
        if (fmi_version, interface) not in peaks:
            command = _fmusim("x86_64-linux")
            fmu = platform_fmus(fmi_version, "x86_64-linux")
            out_dir = tmp_path_factory.mktemp(f"native_{fmi_version}_{interface}")
            peaks[fmi_version, interface] = {
                order: run_fmusim(command, fmu, interface, order, out_dir, fmi_version) for order in ORDERS
            }
        return peaks[fmi_version, interface]

    return get


@pytest.mark.platforms
@pytest.mark.parametrize("interface", list(INTERFACES))
@pytest.mark.parametrize("fmi_version", [2, 3])
@pytest.mark.parametrize("platform", list(FMUSIM_VARIABLES))
def test_fmusim_reproduces_the_published_peaks_on_each_platform(
    platform, fmi_version, interface, platform_fmus, native_peaks, tmp_path, request
):
    if native_platform() != "x86_64-linux":
        pytest.skip("the platform tests compare with the x86_64-linux library: run them on x86-64 Linux")
    command = _fmusim(platform)
    fmu = platform_fmus(fmi_version, platform)
    checked = (
        f"published peaks to {PUBLISHED_ACCURACY:g}, peaks equal to the x86_64-linux library's in the same "
        f"fmusim to {SAME_AS_NATIVE:g}"
    )
    options = " ".join(shlex.quote(o) for o in fmusim_options(interface, (), fmi_version))
    environment = tuple(
        dict.fromkeys(
            f"{FMUSIM_VARIABLES[name]}=path/to/{name}/fmusim{'.exe' if 'windows' in name else ''}"
            for name in ("x86_64-linux", platform)
        )
    )
    with compatibility_row(
        request,
        "fmusim",
        _version(command),
        fmi_version=f"{fmi_version}.0",
        interface=INTERFACES[interface],
        checked=checked,
        platform=platform,
        environment=environment,
        note=(
            f"the Reference FMUs' C fmusim, {_emulator_note(platform)}: fmusim {options} "
            + ("--start-value material 'm_1 ... m_11'" if fmi_version == 3 else "--start-value material[j] m_j")
            + " (each published order)"
        ),
    ) as row:
        native = native_peaks(fmi_version, interface)
        for order in ORDERS:
            peak = run_fmusim(command, fmu, interface, order, tmp_path, fmi_version)
            row.reached(order, peak)
            assert peak == pytest.approx(PUBLISHED_PEAKS[order], rel=PUBLISHED_ACCURACY)
            assert peak == pytest.approx(native[order], rel=SAME_AS_NATIVE, abs=0.0)


@pytest.fixture(scope="session")
def platform_plate(tmp_path_factory):
    """A 5 x 5 x 5 plate as one FMI 3 FMU for every platform (the numpy reference's plate)."""
    missing = _missing_compilers(ALL_PLATFORMS[3])
    if missing:
        pytest.skip(missing)
    return build.build_fmu(
        "armour_11x11",
        tmp_path_factory.mktemp("platform_plate") / "Plate5x5x5-all.fmu",
        rows=5,
        cols=5,
        depth=5,
        werror=True,
        fmi_version=3,
        platforms="all",
    )


@pytest.mark.platforms
@pytest.mark.parametrize("platform", list(FMUSIM_VARIABLES))
def test_fmusim_runs_a_plate_under_a_patch_to_the_reference_on_each_platform(platform, platform_plate, tmp_path):
    """The plate (docs/model.md section 10) struck over a 3 x 3 patch under the mean rule, neither the FMU's
    default, co-simulated by fmusim on each platform: the numpy reference's peak to 1e-7."""
    import json
    from pathlib import Path

    if native_platform() != "x86_64-linux":
        pytest.skip("the platform tests run on x86-64 Linux")
    reference = json.loads(
        (Path(__file__).resolve().parents[1] / "reference" / "plate_5x5x5_reference.json").read_text()
    )
    case = next(c for c in reference["cases"] if c["name"] == "mean-patch3-31524")
    command = _fmusim(platform)
    output = tmp_path / "plate.csv"
    options = [
        "--interface-type",
        "cs",
        "--output-variable",
        "peak_backplate_force",
        "--start-value",
        "load_patch",
        "3",
        "--start-value",
        "diagonal_rule",
        "1",
        "--start-value",
        "rtol",
        "1e-12",
        "--start-value",
        "atol",
        "1e-12",
    ]
    options += order_options(case["scene"]["order"], 3)
    done = subprocess.run(
        [*command, *options, "--output-file", str(output), str(platform_plate)],
        capture_output=True,
        text=True,
        env=_environment(),
        timeout=1800,
    )
    assert done.returncode == 0 and output.is_file(), (done.stderr or done.stdout)[-2000:]
    with open(output, newline="") as handle:
        rows = list(csv.DictReader(handle))
    assert float(rows[-1]["time"]) == 8.0
    assert float(rows[-1]["peak_backplate_force"]) == pytest.approx(case["peak_backplate_force"], rel=1e-7)
