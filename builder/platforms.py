"""The platforms an FMU can carry binaries for, the compiler that builds each, and what a built library is.

One FMU holds one shared library per platform, under the folder each FMI version names for it:

    platform        FMI 2 folder   FMI 3 folder     compiler (found on PATH)   override            Debian package
    x86_64-linux    linux64        x86_64-linux     cc (native)                CC_X86_64_LINUX     gcc
    x86_64-windows  win64          x86_64-windows   x86_64-w64-mingw32-gcc     CC_X86_64_WINDOWS   gcc-mingw-w64-x86-64
    aarch64-linux   linux64        aarch64-linux    aarch64-linux-gnu-gcc      CC_AARCH64_LINUX    gcc-aarch64-linux-gnu

FMI 2 names no folder for aarch64 Linux: FMPy and the Reference FMUs' fmusim load `binaries/linux64` on
aarch64 as on x86-64, so an FMI 2 FMU carries one Linux architecture, and `all` means x86_64-linux and
x86_64-windows there (FMI 3's platform tuples hold all three).

The numbers do not depend on the platform: every build compiles with -ffp-contract=off (no multiply-add
contracted into an FMA: aarch64 GCC contracts by default in its GNU modes) and without -ffast-math (no
reassociation); exp is the library's own (lattice_exp). x86-64 Linux gets the AVX-512/AVX2 clones of the hot loops
(an ifunc, see lattice/compiler.h); Windows has no ifunc, and GCC's target_clones needs one, so Windows gets
one baseline (SSE2) build of the same sources: the clones compute the same bits as the baseline, so the
Windows numbers are the same, only slower. aarch64 gets one build (its vector unit, NEON, is its baseline).
"""

from __future__ import annotations

import os
import platform
import shutil
import struct
from dataclasses import dataclass

# Flags every platform's build adds to builder.build's: the numbers must not depend on the compiler's default.
PORTABLE_FLAGS = ("-ffp-contract=off",)


@dataclass(frozen=True)
class TargetPlatform:
    """A platform the FMU can carry a binary for, and how to build it."""

    name: str  # the FMI 3 platform tuple, also the name given to --platforms
    fmi2_folder: str
    suffix: str  # the shared library's
    cross_compiler: str  # the compiler's usual name where this machine is another platform
    debian_package: str  # the package that installs cross_compiler
    machine: str  # what library_machine() reads in a library built for it
    link_flags: tuple[str, ...] = ()

    @property
    def compiler_variable(self) -> str:
        """The environment variable that overrides the compiler, e.g. CC_X86_64_WINDOWS."""
        return "CC_" + self.name.replace("-", "_").upper()

    def folder(self, fmi_version: int) -> str:
        return self.name if fmi_version == 3 else self.fmi2_folder


PLATFORMS = {
    "x86_64-linux": TargetPlatform(
        "x86_64-linux", "linux64", ".so", "x86_64-linux-gnu-gcc", "gcc-x86-64-linux-gnu", "x86_64"
    ),
    # -static-libgcc: the DLL needs no libgcc_s_seh-1.dll beside it (the Reference FMUs link the same way).
    "x86_64-windows": TargetPlatform(
        "x86_64-windows",
        "win64",
        ".dll",
        "x86_64-w64-mingw32-gcc",
        "gcc-mingw-w64-x86-64",
        "x86_64",
        ("-static-libgcc",),
    ),
    "aarch64-linux": TargetPlatform(
        "aarch64-linux", "linux64", ".so", "aarch64-linux-gnu-gcc", "gcc-aarch64-linux-gnu", "aarch64"
    ),
}
# What --platforms all builds, per FMI version: the platforms one FMU of that version can hold together.
ALL_PLATFORMS = {2: ("x86_64-linux", "x86_64-windows"), 3: ("x86_64-linux", "x86_64-windows", "aarch64-linux")}


def native_platform() -> str | None:
    """This machine's platform tuple, if it is one of PLATFORMS."""
    machine = {"amd64": "x86_64", "x86_64": "x86_64", "arm64": "aarch64", "aarch64": "aarch64"}.get(
        platform.machine().lower()
    )
    system = {"Linux": "linux", "Windows": "windows"}.get(platform.system())
    name = f"{machine}-{system}"
    return name if name in PLATFORMS else None


def parse_platforms(text: str, fmi_version: int) -> tuple[TargetPlatform, ...]:
    """`all` or a comma list of PLATFORMS' names; ValueError (one line) for an unknown name, or for two
    platforms that would share one FMI 2 folder."""
    names = (
        ALL_PLATFORMS[fmi_version]
        if text.strip() == "all"
        else tuple(dict.fromkeys(part.strip() for part in text.split(",") if part.strip()))
    )
    unknown = [name for name in names if name not in PLATFORMS]
    if unknown or not names:
        raise ValueError(f"--platforms {text!r}: allowed values are 'all' or a comma list of {', '.join(PLATFORMS)}")
    chosen = tuple(PLATFORMS[name] for name in names)
    folders: dict[str, str] = {}
    for target in chosen:
        other = folders.setdefault(target.folder(fmi_version), target.name)
        if other != target.name:
            raise ValueError(
                f"--platforms {text!r}: FMI {fmi_version} has one folder, binaries/"
                f"{target.folder(fmi_version)}, for {other} and {target.name} (FMPy and fmusim load it on "
                f"both): build {target.name} into its own FMI 2 FMU, or use --fmi-version 3"
            )
    return chosen


def compiler_for(target: TargetPlatform) -> list[str]:
    """The compiler command for a platform: its CC_<PLATFORM> variable, else (this machine's platform) $CC or
    cc, else the cross compiler's usual name; RuntimeError (one line, naming the package) when it is missing."""
    override = os.environ.get(target.compiler_variable)
    if override:
        command = override.split()
    elif target.name == native_platform():
        command = (os.environ.get("CC") or "cc").split()
    else:
        command = [target.cross_compiler]
    if shutil.which(command[0]) is None:
        raise RuntimeError(
            f"platform {target.name} needs the C compiler {command[0]}, which is not installed: "
            f"apt-get install {target.debian_package} (Debian/Ubuntu), or set "
            f"{target.compiler_variable} to another compiler for {target.name}"
        )
    return command


# ELF e_machine and PE/COFF Machine values of the architectures above.
_ELF_MACHINES = {0x3E: "x86_64", 0xB7: "aarch64"}
_PE_MACHINES = {0x8664: "x86_64", 0xAA64: "aarch64"}


def library_machine(path: str | os.PathLike) -> tuple[str, str]:
    """(format, architecture) of a shared library file: see header_machine."""
    with open(path, "rb") as handle:
        return header_machine(handle.read(4096), str(path))


def header_machine(data: bytes, what: str = "the file") -> tuple[str, str]:
    """(format, architecture) from the first bytes of a shared library: ("ELF", "x86_64"), ("PE", "aarch64"),
    ...; ValueError for what is neither a 64-bit ELF nor a PE image."""
    if data[:4] == b"\x7fELF":
        if data[4] != 2:
            raise ValueError(f"{what}: a 32-bit ELF")
        endian = "<" if data[5] == 1 else ">"
        (machine,) = struct.unpack_from(endian + "H", data, 18)
        return "ELF", _ELF_MACHINES.get(machine, f"unknown machine {machine:#x}")
    if data[:2] == b"MZ":
        (offset,) = struct.unpack_from("<I", data, 0x3C)
        if data[offset : offset + 4] != b"PE\0\0":
            raise ValueError(f"{what}: an MZ file without a PE header")
        (machine,) = struct.unpack_from("<H", data, offset + 4)
        return "PE", _PE_MACHINES.get(machine, f"unknown machine {machine:#x}")
    raise ValueError(f"{what}: neither an ELF nor a PE file")


__all__ = [
    "ALL_PLATFORMS",
    "PLATFORMS",
    "PORTABLE_FLAGS",
    "TargetPlatform",
    "compiler_for",
    "header_machine",
    "library_machine",
    "native_platform",
    "parse_platforms",
]
