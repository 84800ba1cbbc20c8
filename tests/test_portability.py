"""The orchestrator needs nothing POSIX-only on the paths a Windows or macOS user takes.

A study runs in a Python where this project's modules cannot import the POSIX-only modules and ctypes cannot
load the C library (a ``sitecustomize`` shim, inherited by the pool's spawned workers): what Windows lacks.
Libraries keep their own platform code (portalocker imports fcntl on POSIX and msvcrt on Windows; fmpy loads
libc or msvcrt). Linux-only calls
(prctl, renameat2) must then be skipped, not fail, and the run must still lock its folder, resume, and swap
its report in.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import textwrap
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
POSIX_ONLY = ("fcntl", "termios", "pwd", "grp", "resource", "pty", "tty", "syslog")

OURS = ("orchestrator", "fmu_src", "builder", "scenes", "reference", "build_fmu", "__main__")

SHIM = textwrap.dedent(f"""
    import builtins
    import ctypes
    import os
    import sys

    _import = builtins.__import__

    def _hidden(name, globals=None, locals=None, fromlist=(), level=0):
        importer = (globals or {{}}).get("__name__") or ""
        if level == 0 and name.split(".")[0] in {POSIX_ONLY!r} and importer.split(".")[0] in {OURS!r}:
            raise ImportError(f"No module named {{name!r}} (hidden from {{importer}}, as on Windows)")
        return _import(name, globals, locals, fromlist, level)

    builtins.__import__ = _hidden

    _cdll = ctypes.CDLL

    def _no_libc(name, *args, **kwargs):
        caller = sys._getframe(1).f_globals.get("__name__") or ""
        if caller.split(".")[0] in {OURS!r} and (name is None or "libc" in os.path.basename(str(name))):
            with open(os.environ["SHIM_LOG"], "a") as log:
                log.write(f"refused ctypes.CDLL({{name!r}})\\n")
            raise OSError(f"{{name}}: cannot load the C library here")
        return _cdll(name, *args, **kwargs)

    ctypes.CDLL = _no_libc
""")


def run_without_posix(tmp_path, code: str) -> subprocess.CompletedProcess:
    shim = tmp_path / "shim"
    shim.mkdir(exist_ok=True)
    (shim / "sitecustomize.py").write_text(SHIM)
    environment = {
        **os.environ,
        "PYTHONPATH": os.pathsep.join([str(shim), str(ROOT)]),
        "SHIM_LOG": str(tmp_path / "shim.log"),
        "LATTICE_START_METHOD": "spawn",
    }
    return subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, cwd=tmp_path, env=environment, timeout=600
    )


def test_the_shim_hides_fcntl_and_the_c_library(tmp_path):
    done = run_without_posix(
        tmp_path,
        "import ctypes\ntry:\n    import fcntl\nexcept ImportError:\n    pass\n"
        "else:\n    raise SystemExit('fcntl imported')\n"
        "try:\n    ctypes.CDLL(None)\nexcept OSError:\n    print('refused')\n",
    )
    assert done.returncode == 0 and done.stdout.strip() == "refused", done.stderr


def test_a_study_runs_resumes_and_refuses_a_second_run_without_posix_modules(fmu_path, tmp_path):
    out = tmp_path / "out"
    code = textwrap.dedent(f"""
        import orchestrator.run as run
        from orchestrator.runfolder import FolderError, RunFolder

        argv = ["--fmu", {str(fmu_path)!r}, "--out", {str(out)!r}, "--diagonal-rule", "receiver",
                "--budget", "8", "--repeats", "1", "--method", "sa", "--workers", "2", "--executor", "process",
                "--no-sensitivity", "--no-progress"]
        assert run.main(argv) == 0
        held = RunFolder.open({str(out)!r}, resume=True, overwrite=False)
        try:
            RunFolder.open({str(out)!r}, resume=True, overwrite=False)
        except FolderError as exc:
            print("refused:", exc)
        else:
            raise SystemExit("a second run on a locked folder was not refused")
        finally:
            held.release()
        assert run.main(argv + ["--resume"]) == 0
    """)
    done = run_without_posix(tmp_path, code)
    assert done.returncode == 0, done.stderr
    assert "refused: --out" in done.stdout and "is in use by a running run (pid" in done.stdout, done.stdout
    refused = (tmp_path / "shim.log").read_text()
    assert "refused ctypes.CDLL(None)" in refused  # the Linux-only calls were tried, refused and skipped
    results = json.loads((out / "results.json").read_text())
    assert results["answers"], results.keys()
    assert not (tmp_path / "out.partial").exists() and not list(tmp_path.glob(".out.previous-*"))


def test_every_module_of_the_project_imports_without_posix_modules(tmp_path):
    code = textwrap.dedent("""
        import importlib
        import pkgutil

        names = ["build_fmu"]
        for package in ("orchestrator", "fmu_src", "builder", "scenes", "reference"):
            module = importlib.import_module(package)
            names += [package] + [info.name for info in pkgutil.walk_packages(module.__path__, package + ".")]
        for name in names:
            importlib.import_module(name)
        print(len(names), "modules")
    """)
    done = run_without_posix(tmp_path, code)
    assert done.returncode == 0, done.stderr
    assert int(done.stdout.split()[0]) > 30, done.stdout
