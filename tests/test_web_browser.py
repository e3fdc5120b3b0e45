"""The web page in real headless Chromium (Debian's chromium and chromium-driver, driven by
Selenium) against ``mavhelm sim`` and ``mavhelm run --web``: the vehicle marker moves, the task
that steers changes, frames come at 2 Hz or more, and the reason appears when the operator takes
the vehicle back in MANUAL. A screenshot is saved beside the run's logs (``web.png``); the
run's .tlog is read back with pymavlink."""

from __future__ import annotations

import shutil
import time

import pytest
from pymavlink import mavutil

from tests.support.waiting import wait_for
from tests.support.web_rig import LiveRun

pytestmark = pytest.mark.slow

CHROMIUM = shutil.which("chromium")
CHROMEDRIVER = shutil.which("chromedriver")
webdriver = pytest.importorskip("selenium.webdriver")
if CHROMIUM is None or CHROMEDRIVER is None:
    pytest.skip("needs Debian's chromium and chromium-driver (.ci/run installs them)",
                allow_module_level=True)


@pytest.fixture
def browser():
    options = webdriver.ChromeOptions()
    options.binary_location = CHROMIUM
    for arg in ("--headless=new", "--no-sandbox", "--disable-dev-shm-usage", "--disable-gpu",
                "--window-size=1280,800"):
        options.add_argument(arg)
    driver = webdriver.Chrome(options=options,
                              service=webdriver.ChromeService(executable_path=CHROMEDRIVER))
    try:
        yield driver
    finally:
        driver.quit()


def marker(driver) -> tuple[float, float] | None:
    """The NAV marker's position (m), read in one script: the page redraws it every frame."""
    xy = driver.execute_script(
        "const m = document.getElementById('vehicle-nav');"
        "return m ? [m.dataset.x, m.dataset.y] : null;")
    return None if xy is None else (float(xy[0]), float(xy[1]))


def text(driver, element_id: str) -> str:
    return driver.execute_script(f"return document.getElementById('{element_id}').textContent")


def running(driver) -> list[str]:
    return driver.execute_script(
        "return [...document.querySelectorAll('tr.task')].map(r => r.dataset.name)")


def test_the_page_follows_the_vehicle_and_the_helm(tmp_path, browser):
    with LiveRun(tmp_path) as run:
        browser.get(run.url)
        start = wait_for(lambda: marker(browser), 20.0, "the vehicle marker",
                         lambda: browser.page_source[-500:])
        frames0, t0 = browser.execute_script("return window.mavhelmFrames"), time.monotonic()
        time.sleep(3.0)
        rate = (browser.execute_script("return window.mavhelmFrames") - frames0) / (
            time.monotonic() - t0)
        assert rate >= 2.0, f"{rate:.1f} frames a second"
        run.hand_over()
        wait_for(lambda: "OutLeg steers" in text(browser, "steering"), 20.0,
                 "OutLeg to steer", lambda: text(browser, "steering"))
        assert "OutLeg" in running(browser)

        def moved() -> bool:
            now = marker(browser)
            return now is not None and abs(now[0] - start[0]) + abs(now[1] - start[1]) > 10.0
        wait_for(moved, 30.0, "the marker to move 10 m", lambda: (start, marker(browser)))
        wait_for(lambda: "HomeLeg steers" in text(browser, "steering"), 40.0,
                 "HomeLeg to take over", lambda: text(browser, "steering"))
        with run.lock:
            run.gcs.set_mode("MANUAL")
        wait_for(lambda: "offline: autopilot in MANUAL" in text(browser, "why"), 10.0,
                 "the offline reason", lambda: text(browser, "why"))
        assert "helm offline" in text(browser, "helm")
        time.sleep(0.6)
        shot = tmp_path / "web.png"
        browser.save_screenshot(str(shot))
        assert shot.stat().st_size > 10_000
    # the same run's .tlog, closed with the companion, as a ground-station tool reads it
    log = mavutil.mavlink_connection(str(next(tmp_path.glob("web_*.tlog"))))
    kinds = set()
    while (msg := log.recv_match()) is not None:
        kinds.add((msg.get_srcComponent(), msg.get_type()))
    assert {(1, "HEARTBEAT"), (191, "NAMED_VALUE_FLOAT"), (191, "TUNNEL")} <= kinds
