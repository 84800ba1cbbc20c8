"""A second validator: VDMCheck (the INTO-CPS Association's VDM model of the FMI standard) over the FMU.

Opt-in (`python -m pytest -m vdmcheck`; needs java and mvn): the first run fetches VDMCheck for FMI 2 from
Maven Central into the cache (default ~/.cache/mass-spring-lattice, or $MSL_CACHE_DIR). It checks the FMI 2
model description (Model Exchange and Co-Simulation) in about 30 s. VDMCheck for FMI 3 (vdmcheck3) is not
published on Maven Central, so the FMI 3 model description is checked by fmpy's validation only.
"""

from __future__ import annotations

import re
import shutil
import subprocess
import zipfile
from pathlib import Path

import pytest

from test_importers import CACHE_DIR

PROJECT = Path(__file__).resolve().parent / "vdmcheck"
VERSION = re.search(r"<vdmcheck.version>(.+)</vdmcheck.version>", (PROJECT / "pom.xml").read_text()).group(1)

pytestmark = pytest.mark.vdmcheck


@pytest.fixture(scope="module")
def vdmcheck_dir() -> Path:
    """VDMCheck laid out as its release archive is: the jars side by side with the VDM model and the schema,
    which it finds next to its own jar."""
    folder = CACHE_DIR / f"vdmcheck2-{VERSION}"
    if not (folder / "fmi2-static-model").is_dir():
        if shutil.which("mvn") is None or shutil.which("java") is None:
            pytest.skip("VDMCheck needs java and mvn (Debian: apt-get install -y openjdk-17-jdk maven)")
        command = ["mvn", "-B", "-q", "-f", str(PROJECT / "pom.xml"), "process-resources", f"-Dvdmcheck.dir={folder}"]
        result = subprocess.run(command, capture_output=True, text=True, timeout=1800)
        assert result.returncode == 0, f"{' '.join(command)} failed:\n{result.stdout[-3000:]}{result.stderr[-3000:]}"
        for jar, prefix in (
            ("static-model.jar", "fmi2-static-model/"),
            ("rule-model.jar", "fmi2-rule-model/"),
            ("vdmcheck2.jar", "fmi2schema/"),
        ):
            with zipfile.ZipFile(folder / jar) as archive:
                archive.extractall(folder, [name for name in archive.namelist() if name.startswith(prefix)])
    return folder


def vdmcheck(folder: Path, fmu: Path) -> str:
    result = subprocess.run(
        ["java", "-cp", str(folder / "vdmcheck2.jar"), "VDMCheck", str(fmu)],
        capture_output=True,
        text=True,
        timeout=900,
    )
    return result.stdout + result.stderr


def test_vdmcheck_finds_no_error_in_the_fmi2_model_description(vdmcheck_dir, fmu_path):
    output = vdmcheck(vdmcheck_dir, fmu_path)
    assert "Checking modelDescription.xml" in output and "No errors found." in output, output


def test_vdmcheck_finds_a_planted_error(vdmcheck_dir, fmu_path, tmp_path):
    """The check is not vacuous: a derivative pointing at no state is reported."""
    broken = tmp_path / "broken.fmu"
    with zipfile.ZipFile(fmu_path) as source, zipfile.ZipFile(broken, "w") as target:
        for item in source.infolist():
            data = source.read(item)
            if item.filename == "modelDescription.xml":
                data = re.sub(rb'derivative="\d+"', b'derivative="99999"', data, count=1)
            target.writestr(item, data)
    output = vdmcheck(vdmcheck_dir, broken)
    assert "Errors found." in output and "InitialUnknowns" in output, output
