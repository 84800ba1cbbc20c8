"""The FMU's FMI-LS-REF files (builder/reference_results.py): the manifest is what the layered standard and FMI 3's
manifest schema ask for, its results are there and are the published orders', and today's FMU still gives them.

No checker of FMI-LS-REF manifests is published with a schema of its own (the layered standard is an alpha), so
the manifest is validated against a schema of the structure the Reference FMUs ship (fmiReferences of Related
elements with type, source, role and description), whose root attributes are FMI 3's own attribute group for
layered-standard manifests, read from the fmi3LayeredStandardManifest.xsd that FMPy ships.
"""

from __future__ import annotations

import csv
import io
import zipfile
from pathlib import Path

import numpy as np
import pytest
from fmpy import read_model_description
from lxml import etree

from builder import build
from fmu_src.published import PUBLISHED_PEAKS
from builder.reference_results import EXTRA, MANIFEST, REFERENCE_RESULTS, RESULTS_DIR, SIGNALS, simulate

LS = "http://fmi-standard.org/fmi-ls-manifest"
# Off the recording's C library (libm's pow, expm1) the step sequence may differ by a step: the outputs then
# agree to the FMU's accuracy, scaled by each output's range.
ACCURACY = 1e-5


def manifest_schema() -> etree.XMLSchema:
    import fmpy

    standard = Path(fmpy.__file__).parent / "schema" / "fmi3" / "fmi3LayeredStandardManifest.xsd"
    text = f"""<?xml version="1.0" encoding="UTF-8"?>
<xs:schema xmlns:xs="http://www.w3.org/2001/XMLSchema" xmlns:fmi-ls="{LS}">
  <xs:import namespace="{LS}" schemaLocation="{standard.as_uri()}"/>
  <xs:element name="fmiReferences">
    <xs:complexType>
      <xs:sequence>
        <xs:element name="Related" minOccurs="1" maxOccurs="unbounded">
          <xs:complexType>
            <xs:attribute name="type" type="xs:normalizedString" use="required"/>
            <xs:attribute name="source" type="xs:anyURI" use="required"/>
            <xs:attribute name="role" type="xs:normalizedString" use="required"/>
            <xs:attribute name="description" type="xs:normalizedString"/>
          </xs:complexType>
        </xs:element>
      </xs:sequence>
      <xs:attributeGroup ref="fmi-ls:ALayeredStandardManifest"/>
    </xs:complexType>
  </xs:element>
</xs:schema>"""
    return etree.XMLSchema(etree.fromstring(text.encode()))


def _columns(text: str) -> dict[str, np.ndarray]:
    rows = list(csv.reader(io.StringIO(text)))
    return {name: np.array([float(row[index]) for row in rows[1:]]) for index, name in enumerate(rows[0])}


@pytest.mark.parametrize("version", [2, 3])
def test_the_fmu_carries_the_published_orders_results_under_a_valid_manifest(fmu_path, fmu3_path, version):
    fmu = fmu_path if version == 2 else fmu3_path
    description = read_model_description(str(fmu))
    outputs = {v.name for v in description.modelVariables if v.causality == "output"}
    with zipfile.ZipFile(fmu) as archive:
        names = [name for name in archive.namelist() if name.startswith("extra/")]
        manifest = etree.fromstring(archive.read(f"{EXTRA}/{MANIFEST}"))
        schema = manifest_schema()
        assert schema.validate(manifest), schema.error_log.last_error
        assert manifest.get(f"{{{LS}}}fmi-ls-name") == "org.fmi-standard.fmi-ls-ref"
        related = manifest.findall("Related")
        assert sorted(names) == sorted([f"{EXTRA}/{MANIFEST}"] + [f"{EXTRA}/{r.get('source')}" for r in related])
        assert [r.get("source") for r in related] == [r.file_name("MassSpringLattice") for r in REFERENCE_RESULTS]
        step = float(description.defaultExperiment.stepSize)
        stop = float(description.defaultExperiment.stopTime)
        for element, reference in zip(related, REFERENCE_RESULTS):
            assert (element.get("type"), element.get("role")) == ("text/csv", "result")
            assert " ".join(map(str, reference.order)) in element.get("description")
            columns = _columns(archive.read(f"{EXTRA}/{element.get('source')}").decode())
            assert list(columns) == ["time", *SIGNALS] and set(SIGNALS) <= outputs
            np.testing.assert_allclose(columns["time"], np.arange(round(stop / step) + 1) * step, rtol=0, atol=1e-12)
            assert columns["peak_backplate_force"][-1] == pytest.approx(PUBLISHED_PEAKS[reference.order], rel=1e-6)


@pytest.mark.parametrize("reference", REFERENCE_RESULTS, ids=lambda r: r.suffix.strip("_"))
def test_todays_fmu_gives_the_recorded_reference_results(fmu_path, reference):
    recorded = _columns((RESULTS_DIR / reference.file_name("MassSpringLattice")).read_text())
    run = simulate(fmu_path, reference.order)
    np.testing.assert_allclose(run["time"], recorded["time"], rtol=0, atol=1e-12)
    for name in SIGNALS:
        scale = max(np.abs(recorded[name]).max(), 1e-300)
        assert np.abs(run[name] - recorded[name]).max() <= ACCURACY * scale, name


def test_an_fmu_of_another_scene_or_size_carries_no_reference_results(tmp_path):
    """The published results hold for the study's armour scene only; other FMUs have none to carry."""
    for fmu in (
        build.build_fmu("free_5x5", tmp_path / "free.fmu"),
        build.build_fmu(rows=7, output=tmp_path / "armour7x11.fmu"),
    ):
        with zipfile.ZipFile(fmu) as archive:
            assert not [name for name in archive.namelist() if name.startswith("extra/")]
