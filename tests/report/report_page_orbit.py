#!/usr/bin/python3
"""Drives the report page's 3D view in headless Chromium (Debian's chromium and chromedriver, through Selenium)
as a user would: a drag on the view must turn the camera about its target (same distance, another position), a
wheel turn away from the user must move it away from the target (zoom out), and the page must log no error.
The page writes the camera into #report-state (data-camera, data-camera-target). Waits are "until true or a
generous deadline", never a measured duration. Exit 0 when all holds, 1 naming what failed."""
import argparse, json, math, sys, time
from selenium import webdriver
from selenium.webdriver.chrome.service import Service
from selenium.webdriver.common.action_chains import ActionChains
from selenium.webdriver.common.actions.wheel_input import ScrollOrigin
from selenium.webdriver.common.by import By

ap = argparse.ArgumentParser()
ap.add_argument('--page', required=True)        # report.html
ap.add_argument('--screenshot', required=True)  # the view after the drag and the zoom
ap.add_argument('--deadline-s', type=float, default=120)
a = ap.parse_args()

opts = webdriver.ChromeOptions()
for flag in ('--headless=new', '--no-sandbox', '--disable-dev-shm-usage', '--window-size=1400,1000',
             '--enable-unsafe-swiftshader'):
    opts.add_argument(flag)
opts.set_capability('goog:loggingPrefs', {'browser': 'ALL'})
driver = webdriver.Chrome(service=Service('/usr/bin/chromedriver'), options=opts)
failures = []


def attr(name):
    return driver.find_element(By.ID, 'report-state').get_attribute(name)


def wait_until(what, cond):
    end = time.time() + a.deadline_s
    while not cond():
        if time.time() > end:
            failures.append(what + ': not seen before the deadline')
            return False
        time.sleep(0.2)
    return True


def camera():
    return json.loads(attr('data-camera')), json.loads(attr('data-camera-target'))


try:
    driver.get('file://' + a.page + '#only=map_3d')
    if wait_until('page drawn', lambda: attr('data-ready') == '1') and attr('data-webgl') == '1':
        canvas = driver.find_element(By.CSS_SELECTOR, '#map_3d-view canvas')
        pos0, target = camera()
        dist0 = math.dist(pos0, target)
        ActionChains(driver).move_to_element(canvas).click_and_hold().move_by_offset(150, 60).release().perform()
        wait_until('camera moved by the drag', lambda: camera()[0] != pos0)
        pos1, target1 = camera()
        dist1 = math.dist(pos1, target1)
        print(f'drag: camera {pos0} -> {pos1}, distance to target {dist0:.4f} -> {dist1:.4f} m')
        if math.dist(pos0, pos1) < 0.05 * dist0:
            failures.append(f'the drag did not turn the view (camera {pos0} -> {pos1})')
        if abs(dist1 - dist0) > 1e-3 * dist0:
            failures.append(f'the drag changed the distance to the target ({dist0} -> {dist1}): not an orbit')
        ActionChains(driver).scroll_from_origin(ScrollOrigin.from_element(canvas), 0, 400).perform()
        wait_until('camera moved by the wheel', lambda: camera()[0] != pos1)
        pos2, target2 = camera()
        dist2 = math.dist(pos2, target2)
        print(f'wheel: distance to target {dist1:.4f} -> {dist2:.4f} m')
        if not dist2 > dist1 * 1.05:
            failures.append(f'the wheel did not zoom out (distance {dist1} -> {dist2})')
        driver.save_screenshot(a.screenshot)
    else:
        failures.append('no WebGL 3D view on the page')
    errors = [e['message'] for e in driver.get_log('browser') if e['level'] == 'SEVERE']
    errors += json.loads(attr('data-errors') or '[]')
    if errors:
        failures.append('console errors: ' + '; '.join(errors))
finally:
    driver.quit()

for f in failures:
    print('FAIL:', f)
sys.exit(1 if failures else 0)
