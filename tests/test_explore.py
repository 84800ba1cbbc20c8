"""explore.html: one self-contained page that opens offline, in a real browser (Debian's chromium and
chromium-driver through Selenium): no console error with the network cut off, its table holds every evaluation
of evaluations.csv, a click on a row or on a point of the Pareto front shows that design."""

from __future__ import annotations

import csv
import json
import re
import shutil
import time
from pathlib import Path

import pytest

from command_line import main

QUICK = ["--repeats", "1", "--no-sensitivity", "--no-progress", "--executor", "serial"]
CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")
CHROMEDRIVER = shutil.which("chromedriver")


@pytest.fixture(scope="module")
def one_objective(fmu_path, tmp_path_factory):
    out = tmp_path_factory.mktemp("explore") / "results"
    assert main("--fmu", fmu_path, "--out", out, "--budget", "15", "--method", "cmaes", "sa", "sequential", *QUICK) == 0
    return out


@pytest.fixture(scope="module")
def two_objectives(fmu_path, tmp_path_factory):
    out = tmp_path_factory.mktemp("explore2") / "results"
    assert (
        main(
            "--fmu",
            fmu_path,
            "--out",
            out,
            "--objective",
            "sampled,max_compression",
            "--budget",
            "30",
            "--diagonal-rule",
            "mean",
            *QUICK,
        )
        == 0
    )
    return out


def csv_rows(folder: Path) -> list[dict]:
    with (folder / "evaluations.csv").open() as handle:
        return list(csv.DictReader(handle))


def page_data(folder: Path) -> dict:
    text = (folder / "explore.html").read_text()
    found = re.search(r'<script type="application/json" id="study-data">(.*?)</script>', text, re.S)
    return json.loads(found.group(1).replace("<\\/", "</"))


@pytest.mark.parametrize("which", ["one_objective", "two_objectives"])
def test_the_page_is_self_contained_and_holds_every_evaluation(which, request):
    folder = request.getfixturevalue(which)
    text = (folder / "explore.html").read_text()
    # nothing is loaded from elsewhere: no external script, style, image or frame (plotly.js is inlined)
    assert not re.search(r"""<(script|link|img|iframe)[^>]+(src|href)=["']?(https?:)?//""", text, re.I)
    assert "<script src" not in text and 'href="explore.html"' in (folder / "report.html").read_text()
    data = page_data(folder)
    searched = [e for e in data["evaluations"] if e["fidelity"] == "search"]
    rows = csv_rows(folder)
    assert len(searched) == len(rows)
    for e, row in zip(searched, rows):
        assert (
            e["rule"],
            e["method"],
            str(e["seed"]),
            str(e["index"]),
            " ".join(map(str, e["order"])),
            e["status"],
        ) == (row["diagonal_rule"], row["method"], row["seed"], row["index"], row["order"], row["status"])
        assert (e["value"] is None and row["value"] == "") or e["value"] == float(row["value"])
    record = json.loads((folder / "results.json").read_text())
    for front in data["fronts"]:  # every front point has its design file in the folder
        assert front["points"] and all((folder / p["design_file"]).is_file() for p in front["points"])
    assert len(data["fronts"]) == len({p["diagonal_rule"] for p in record["pareto"]})


needs_browser = pytest.mark.skipif(
    CHROMIUM is None or CHROMEDRIVER is None,
    reason="needs Debian's chromium and chromium-driver (apt-get install chromium chromium-driver)",
)


@pytest.fixture()
def browser():
    webdriver = pytest.importorskip("selenium.webdriver", reason="needs selenium (the test extra)")
    from selenium.webdriver.chrome.service import Service

    options = webdriver.ChromeOptions()
    options.binary_location = CHROMIUM
    # the network is cut off: every request would go to a proxy where nothing listens
    for argument in (
        "--headless=new",
        "--no-sandbox",
        "--disable-gpu",
        "--disable-dev-shm-usage",
        "--proxy-server=127.0.0.1:9",
        "--proxy-bypass-list=<-loopback>",
        "--window-size=1300,1800",
    ):
        options.add_argument(argument)
    options.set_capability("goog:loggingPrefs", {"browser": "ALL"})
    driver = webdriver.Chrome(service=Service(CHROMEDRIVER), options=options)
    try:
        yield driver
    finally:
        driver.quit()


def open_page(driver, folder: Path) -> None:
    driver.get((folder / "explore.html").resolve().as_uri())
    for _ in range(100):
        if driver.execute_script("return document.readyState") == "complete" and driver.execute_script(
            "return document.querySelectorAll('#evaluations tbody tr').length"
        ):
            return
        time.sleep(0.1)


def console_errors(driver) -> list[str]:
    return [entry["message"] for entry in driver.get_log("browser") if entry["level"] == "SEVERE"]


def design_text(driver) -> str:
    return driver.find_element("id", "design-text").text


@needs_browser
@pytest.mark.parametrize("which", ["one_objective", "two_objectives"])
def test_the_page_works_in_a_browser_offline(which, request, browser):
    check_page(browser, request.getfixturevalue(which), front=which == "two_objectives")


@pytest.mark.slow
@needs_browser
@pytest.mark.parametrize("options", [[], ["--objective", "sampled,max_compression"]], ids=["default", "two"])
def test_the_default_studys_page_works_in_a_browser_offline(fmu_path, tmp_path, browser, options):
    """The default study (and its two-objective variant) as the command line runs it, without --budget."""
    out = tmp_path / "results"
    assert main("--fmu", fmu_path, "--out", out, "--no-progress", *options) == 0
    check_page(browser, out, front=bool(options))


def check_page(browser, folder: Path, front: bool) -> None:
    from selenium.webdriver.common.action_chains import ActionChains

    open_page(browser, folder)
    assert browser.execute_script("return typeof Plotly") == "object"
    rows = csv_rows(folder)
    table = browser.execute_script(
        "return [...document.querySelectorAll('#evaluations tbody tr[data-fidelity=search]')]"
        ".map(tr => [...tr.children].slice(0, 5).map(td => td.textContent))"
    )
    assert table == [[r["diagonal_rule"], r["method"], r["seed"], r["index"], r["order"]] for r in rows]
    runs = {(r["diagonal_rule"], r["method"], r["seed"]) for r in rows}
    assert browser.execute_script(
        "return document.querySelectorAll('#convergence .scatterlayer .trace').length"
    ) == len(runs)
    # sorting by value puts the lowest first; a filter keeps only what matches
    value_header = browser.find_element("css selector", "#evaluations th[data-column=value]")
    value_header.click()
    values = browser.execute_script(
        "return [...document.querySelectorAll('#evaluations tbody tr')].map(tr => tr.children[6].textContent)"
    )
    numbers = [float(v.replace(",", "")) for v in values if v not in ("n/a",) and not v.startswith(">")]
    assert numbers == sorted(numbers)
    # a click on a row shows that design
    row = browser.find_elements("css selector", "#evaluations tbody tr")[3]
    order = row.find_elements("tag name", "td")[4].text
    row.click()
    assert "[" + order.replace(" ", ", ") + "]" in design_text(browser)
    if front:
        data = page_data(folder)
        point = browser.find_elements("css selector", "#front-0 .scatterlayer .trace:nth-of-type(2) .points path")[1]
        browser.execute_script("arguments[0].scrollIntoView({block: 'center'})", point)
        for _ in range(3):  # plotly takes the point under the mouse from its (throttled) hover: move, wait, click
            ActionChains(browser).move_to_element(point).pause(0.4).click().perform()
            time.sleep(0.5)
            shown = design_text(browser)
            if "front" in shown:
                break
        assert f"on the {data['fronts'][0]['rule']} rule's front" in shown, shown
        clicked = [p for p in data["fronts"][0]["points"] if "[" + ", ".join(map(str, p["order"])) + "]" in shown]
        assert len(clicked) == 1, shown
        link = browser.find_element("id", "design-file").get_attribute("href")
        assert link.endswith(clicked[0]["design_file"]) and (folder / clicked[0]["design_file"]).is_file()
    assert console_errors(browser) == []


@needs_browser
def test_the_browser_of_these_tests_has_no_network(browser, tmp_path):
    """What makes "no console error" mean "works offline": a page that loads anything from the network fails."""
    page = tmp_path / "online.html"
    page.write_text('<!DOCTYPE html><html><body><img src="http://example.org/logo.png"></body></html>')
    browser.get(page.as_uri())
    time.sleep(1)
    assert any("example.org" in message for message in console_errors(browser))
