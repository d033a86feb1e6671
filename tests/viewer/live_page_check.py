#!/usr/bin/python3
"""Drives headless Chromium (Debian's chromium and chromedriver, through Selenium) against the live viewer page
and checks what the page shows, in three phases the test script steps through with marker files:
  1. two tabs load the page (two browsers at once);
  2. once the walk plays: the left image changes, a disparity map with its colour scale is shown, every
     trajectory source has points, the 3D view has points and then the mapper's map, the health table lists every expected process and
     none is stopped; screenshots of the page;
  3. after the script stopped one process: its row turns stale (red) while the others stay live.
No console error may appear. Waits are "until true or a generous deadline", never a measured rate."""
import argparse, json, os, sys, time
from selenium import webdriver
from selenium.webdriver.chrome.service import Service

ap = argparse.ArgumentParser()
ap.add_argument('--url', required=True)
ap.add_argument('--work', required=True)          # marker files and screenshots
ap.add_argument('--processes', required=True)     # comma-separated rows the table must list
ap.add_argument('--sources', required=True)       # comma-separated trajectory sources that must have points
ap.add_argument('--stopped', required=True)       # the process the script stops in phase 3
ap.add_argument('--deadline-s', type=float, default=180)
a = ap.parse_args()

opts = webdriver.ChromeOptions()
for flag in ('--headless=new', '--no-sandbox', '--disable-dev-shm-usage', '--window-size=1400,1300',
             '--use-gl=angle', '--use-angle=swiftshader', '--enable-unsafe-swiftshader'):
    opts.add_argument(flag)
opts.set_capability('goog:loggingPrefs', {'browser': 'ALL'})
driver = webdriver.Chrome(service=Service('/usr/bin/chromedriver'), options=opts)
failures = []

def fail(msg):
    print('FAIL:', msg)
    failures.append(msg)

def state(handle):
    driver.switch_to.window(handle)
    return driver.execute_script('return window.viewerState')

def wait(handle, what, cond):
    end = time.time() + a.deadline_s
    s = state(handle)
    while not cond(s):
        if time.time() > end:
            fail(f'{what}: not seen before the deadline; page state {json.dumps(s)[:1500]}')
            return s
        time.sleep(0.5)
        s = state(handle)
    print('ok:', what)
    return s

def console_errors():
    errors = []
    for h in driver.window_handles:
        driver.switch_to.window(h)
        errors += [e['message'] for e in driver.get_log('browser') if e['level'] == 'SEVERE']
        errors += state(h)['errors']
    return errors

def marker(name):
    open(os.path.join(a.work, name), 'w').close()

def await_marker(name):
    end = time.time() + a.deadline_s
    while not os.path.exists(os.path.join(a.work, name)):
        if time.time() > end:
            fail(f'the test script never wrote {name}')
            return
        time.sleep(0.2)

try:
    driver.get(a.url)
    first = driver.current_window_handle
    driver.switch_to.new_window('tab')
    driver.get(a.url)
    second = driver.current_window_handle
    for h in (first, second):
        wait(h, 'page connected to the event stream', lambda s: s['connected'])
    marker('browsers_ready')

    processes = a.processes.split(',')
    sources = a.sources.split(',')
    s0 = state(first)
    wait(first, 'the left image updates (three new pictures)', lambda s: s['imageUpdates'] >= 3)
    seq_a = state(first)['imageSeq']
    wait(first, 'the left image shows a later pair', lambda s: s['imageSeq'] > seq_a)
    wait(first, 'a disparity map is shown', lambda s: s['disparityUpdates'] >= 1)
    wait(first, 'every trajectory source has points: ' + a.sources,
         lambda s: all(s['trajectoryPoints'].get(n, 0) >= 10 for n in sources))
    wait(first, 'the 3D view holds the points of a disparity map or of the map',
         lambda s: s['cloudPoints'] > 1000 or s['mapPoints'] > 1000)
    wait(first, "the mapper's georeferenced points reach the 3D view", lambda s: s['mapPoints'] > 1000)
    wait(first, 'the health table lists every process live: ' + a.processes,
         lambda s: set(processes) <= {r['process'] for r in s['healthRows'] if not r['stale']})
    # The tracker's epipolar integrity shows in its row: the state (1: rows match) and the counters.
    integrity_cell = (
        "const head = [...document.querySelectorAll('#health thead th')].map(e => e.textContent);"
        "const row = [...document.querySelectorAll('#health tbody tr')].find(r => r.cells[0].textContent === 'tracker');"
        "return row ? row.cells[head.indexOf('integrity')].textContent : '';")
    end = time.time() + a.deadline_s
    while 'state 1' not in driver.execute_script(integrity_cell) and time.time() < end:
        time.sleep(0.2)
    cell = driver.execute_script(integrity_cell)
    if 'state 1' not in cell or 'alarms 0' not in cell:
        fail(f"the tracker's integrity column does not show rows matching without alarms: '{cell}'")
    else:
        print('ok: the tracker row shows its epipolar integrity:', cell)
    # The second tab (a second browser on the same viewer) gets the same stream.
    wait(second, 'a second browser gets pictures and trajectory too',
         lambda s: s['imageUpdates'] >= 1 and all(s['trajectoryPoints'].get(n, 0) >= 10 for n in sources))
    driver.switch_to.window(first)
    # The colour scale under the disparity map has its tick labels.
    ticks = driver.execute_script("return [...document.querySelectorAll('#colourbar-ticks span')].map(e => e.textContent)")
    if len(ticks) < 2 or ticks[0] == ticks[-1]:
        fail(f'the disparity colour scale has no tick labels: {ticks}')
    if not driver.execute_script("return document.getElementById('colourbar').naturalWidth > 0"):
        fail('the colour scale picture did not load')
    driver.execute_script("document.getElementById('show-right').click()")
    wait(first, 'the right image on demand', lambda s: s['rightUpdates'] >= 1)
    driver.save_screenshot(os.path.join(a.work, 'viewer_live.png'))
    marker('live_checked')

    await_marker('process_stopped')
    wait(first, f'{a.stopped} is shown stopped, the others live',
         lambda s: any(r['process'] == a.stopped and r['stale'] for r in s['healthRows']) and
         all(not r['stale'] for r in s['healthRows'] if r['process'] == 'viewer'))
    red = driver.execute_script(
        "return [...document.querySelectorAll('#health tbody tr.stale td:first-child')].map(e => e.textContent)")
    if a.stopped not in red:
        fail(f'the stopped process is not drawn red: red rows {red}')
    driver.save_screenshot(os.path.join(a.work, 'viewer_stopped.png'))
    errors = console_errors()
    if errors:
        fail(f'console errors: {errors}')
finally:
    driver.quit()
print('PASS: live page' if not failures else f'{len(failures)} failures')
sys.exit(1 if failures else 0)
