"""The README's picture of the studio: ``foldprint studio helix_uniform`` started as a user
starts it, its page opened in headless Chromium (Selenium, the system chromedriver), the
jam verdict and its sweep waited for (the findings are then check's), the first finding that names panels or a hinge clicked (its items
highlighted), and the window saved as ``docs/img/studio.png``.

``python scripts/studio_screenshot.py [--design helix_uniform] [--out docs/img/studio.png]``
"""

from __future__ import annotations

import argparse
import os
import re
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--design", default="helix_uniform")
    ap.add_argument("--out", type=Path, default=ROOT / "docs" / "img" / "studio.png")
    ap.add_argument("--size", default="1400,1500", help="window width,height in pixels")
    a = ap.parse_args(argv)
    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service
    from selenium.webdriver.common.by import By
    from selenium.webdriver.support.ui import WebDriverWait

    tmp = Path(tempfile.mkdtemp(prefix="studio-shot-"))
    proc = subprocess.Popen([sys.executable, "-m", "foldprint", "studio", a.design, "--no-browser", "--port", "0",
                             "--out", str(tmp)], stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True,
                            env=dict(os.environ, PYTHONPATH=str(ROOT), PYTHONUNBUFFERED="1"))
    driver = None
    try:
        url = re.search(r"http://\S+", proc.stdout.readline()).group(0)
        opts = webdriver.ChromeOptions()
        opts.binary_location = shutil.which("chromium") or shutil.which("chromium-browser")
        for arg in ("--headless=new", "--no-sandbox", "--disable-gpu", "--disable-dev-shm-usage", "--hide-scrollbars",
                    "--use-angle=swiftshader", "--enable-unsafe-swiftshader", f"--window-size={a.size}",
                    f"--user-data-dir={tmp / 'profile'}"):
            opts.add_argument(arg)
        driver = webdriver.Chrome(service=Service(shutil.which("chromedriver") or "/usr/bin/chromedriver"),
                                  options=opts)
        driver.get(url)
        WebDriverWait(driver, 120, 0.2).until(
            lambda d: d.find_element(By.ID, "verdict").get_attribute("data-sweep") == "done")  # check's findings
        for li in driver.find_elements(By.CSS_SELECTOR, "#findings li.error, #findings li.warning"):
            li.click()
            if driver.find_elements(By.CSS_SELECTOR, ".hl"):
                break
        driver.switch_to.frame(driver.find_element(By.ID, "player"))
        WebDriverWait(driver, 60).until(lambda d: d.execute_script(
            "return document.body && document.body.getAttribute('data-ready') === '1'"))
        driver.execute_script("location.hash = '#t=0.6'")
        driver.switch_to.default_content()
        time.sleep(1.5)
        a.out.parent.mkdir(parents=True, exist_ok=True)
        driver.save_screenshot(str(a.out))
        print(f"wrote {a.out}")
    finally:
        if driver is not None:
            driver.quit()
        proc.terminate()
        proc.wait(timeout=30)
        shutil.rmtree(tmp, ignore_errors=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
