"""The studio's page in a real headless Chromium (Selenium with the system chromedriver):
``foldprint studio helix_uniform`` started as a user starts it, its printed URL opened,
its jam verdict seen to fail, its hinges changed one select at a time to helix_graded's
materials, the verdict seen to pass, the design saved and the saved file read back, and
not one error in the browser's console (the page's and the 3D player's)."""

from __future__ import annotations

import os
import re
import shutil
import socket
import subprocess
import sys
import time
from pathlib import Path

import pytest

webdriver = pytest.importorskip("selenium.webdriver", reason="selenium is not installed (pip install -e '.[test]')")
from selenium.webdriver.chrome.service import Service  # noqa: E402
from selenium.webdriver.common.by import By  # noqa: E402
from selenium.webdriver.support.ui import Select, WebDriverWait  # noqa: E402

from foldprint.io.load import load_design  # noqa: E402
from foldprint.io.templates import resolve_design_path  # noqa: E402

CHROMEDRIVER = shutil.which("chromedriver") or ("/usr/bin/chromedriver" if os.path.exists("/usr/bin/chromedriver")
                                                else None)
CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")

pytestmark = pytest.mark.skipif(CHROMEDRIVER is None or CHROMIUM is None,
                                reason="chromium and chromium-driver (chromedriver) are needed on PATH for the "
                                       "studio's browser test (apt-get install chromium chromium-driver)")


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@pytest.fixture
def studio(tmp_path):
    port = _free_port()
    proc = subprocess.Popen([sys.executable, "-m", "foldprint", "studio", "helix_uniform", "--no-browser",
                             "--port", str(port), "--out", str(tmp_path)], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, env=dict(os.environ, PYTHONUNBUFFERED="1"))
    try:
        line = proc.stdout.readline()
        m = re.search(rf"http://127\.0\.0\.1:{port}/\?token=\S+", line)
        assert m, line + (proc.stderr.read() if proc.poll() is not None else "")
        yield m.group(0), tmp_path
    finally:
        proc.terminate()
        try:
            proc.wait(timeout=20)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait()


@pytest.fixture
def browser(tmp_path):
    opts = webdriver.ChromeOptions()
    opts.binary_location = CHROMIUM
    for arg in ("--headless=new", "--no-sandbox", "--disable-gpu", "--disable-dev-shm-usage", "--no-first-run",
                "--disable-background-networking", "--disable-extensions", "--use-angle=swiftshader",
                "--enable-unsafe-swiftshader", "--window-size=1400,1000", f"--user-data-dir={tmp_path / 'profile'}"):
        opts.add_argument(arg)
    opts.set_capability("goog:loggingPrefs", {"browser": "ALL"})
    driver = webdriver.Chrome(service=Service(CHROMEDRIVER), options=opts)
    try:
        yield driver
    finally:
        driver.quit()


def _verdict(driver, timeout: float, revision: str | None = None) -> tuple[str, str]:
    """Wait for a decided verdict (of ``revision`` when given): (verdict, revision)."""
    def decided(d):
        box = d.find_element(By.ID, "verdict")
        if box.get_attribute("data-state") != "decided":
            return False
        rev = box.get_attribute("data-revision")
        return (box.get_attribute("data-verdict"), rev) if revision is None or rev == revision else False

    return WebDriverWait(driver, timeout, poll_frequency=0.2).until(decided)


def test_the_studio_page_turns_a_failing_helix_into_a_passing_one(studio, browser):
    url, folder = studio
    driver = browser
    driver.get(url)
    WebDriverWait(driver, 60).until(lambda d: d.find_element(By.ID, "revision").text == "revision 1")
    assert driver.current_url.endswith("/") and "token" not in driver.current_url  # the cookie holds it now
    # the flat layout and the timeline are drawn: 10 panels, 9 hinges
    assert len(driver.find_elements(By.CSS_SELECTOR, "#layout path[data-panel]")) == 10
    assert len(driver.find_elements(By.CSS_SELECTOR, "#timeline rect[data-hinge]")) == 9
    verdict, _ = _verdict(driver, 90)
    assert verdict == "error"  # helix_uniform jams under scatter (check fails it)
    banner = WebDriverWait(driver, 30).until(lambda d: d.find_element(By.ID, "status").get_attribute("data-jam"))
    status = driver.find_element(By.ID, "status")
    assert banner == "error" and "jam test: FAIL" in status.text and "fail" in status.get_attribute("class")
    # every running state the verdict box shows from here on, with its estimate and interval
    driver.execute_script("""window.seenRunning = [];
      new MutationObserver(function () {
        var e = document.querySelector('#verdict[data-state="running"] .estimate');
        if (e) window.seenRunning.push(e.textContent);
      }).observe(document.getElementById('verdict'), {childList: true, subtree: true});""")

    graded = [h.material for h in load_design(resolve_design_path("helix_graded")).hinges]
    for k, material in enumerate(graded, start=1):
        rev = driver.find_element(By.ID, "revision").text
        select = Select(driver.find_element(By.CSS_SELECTOR, f'select[data-hinge="h{k}"]'))
        if select.first_selected_option.get_attribute("value") == material:
            continue
        select.select_by_value(material)
        WebDriverWait(driver, 60).until(lambda d: d.find_element(By.ID, "revision").text != rev)
    final = driver.find_element(By.ID, "revision").text.split()[-1]
    shown = [Select(driver.find_element(By.CSS_SELECTOR, f'select[data-hinge="h{k}"]')).first_selected_option
             .get_attribute("value") for k in range(1, 10)]
    assert shown == graded
    verdict, _ = _verdict(driver, 120, final)
    assert verdict == "pass"
    running = driver.execute_script("return window.seenRunning;")
    assert any(re.search(r"so far \d+\.\d %, 95\.0 % interval \d+\.\d % - \d+\.\d %", t) for t in running), running
    WebDriverWait(driver, 30).until(lambda d: d.find_element(By.ID, "status").get_attribute("data-jam") == "pass")
    assert "jam test: PASS" in driver.find_element(By.ID, "status").text

    name = driver.find_element(By.ID, "save-name")
    name.clear()
    name.send_keys("graded_in_the_studio.toml")
    driver.find_element(By.ID, "save").click()
    saved = WebDriverWait(driver, 30).until(lambda d: d.find_element(By.ID, "files").get_attribute("data-saved"))
    assert Path(saved) == folder / "graded_in_the_studio.toml"
    again = load_design(saved)
    assert [h.material for h in again.hinges] == graded
    reference = load_design(resolve_design_path("helix_graded"))
    assert [h.angle for h in again.hinges] == pytest.approx([h.angle for h in reference.hinges])

    # the 3D player loaded in its frame (three.js drew into its canvas)
    driver.switch_to.frame(driver.find_element(By.ID, "player"))
    WebDriverWait(driver, 60).until(lambda d: d.find_elements(By.ID, "view"))
    driver.switch_to.default_content()
    time.sleep(0.5)
    severe = [e for e in driver.get_log("browser") if e["level"] == "SEVERE"]
    assert severe == [], severe
