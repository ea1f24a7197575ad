#!/usr/bin/python3
"""The installer's web console in a real browser (headless Chromium through Selenium).

Registered as the CTest Console.Browser (tests/CMakeLists.txt):

    /usr/bin/python3 tests/console/console_test.py BIN_DIR SOURCE_DIR [unittest options and names]

BIN_DIR holds the programs (build/bin), SOURCE_DIR is the repository. One fixture serves the
whole module, started once: a small bake of the sample site, a 30-frame HMD camera recording,
mosquitto on a free loopback port, skylit-sky-node on a simulated clear day (two skies a
second) and two HMD nodes (skylit-live, hmd-1 and hmd-2, headless, the recording looping), all
in a temporary folder (the site, config/sample_site.yaml, copied there with its planes at the
bake's 40x24 texels) that is removed at the end (SKYLIT_CONSOLE_KEEP=1 keeps it, with every
program's log). The tests:

  FixtureCheck        the fixture itself over HTTP (no browser): both HMD nodes running, /site
                      lists them; `console_test.py BIN SRC FixtureCheck` runs it alone
  ConsoleViews        every view of hmd-1's console (#sky, #hmd, #bake) and of the sky node's
                      (#site, #sky, #bake): no JavaScript error, its images load, its values
                      equal /status (or /site) read right after the page
  ConsoleScreenshots  each view at tablet (1024x768) and phone (390x844) sizes, saved as PNGs in
                      $SKYLIT_CONSOLE_SCREENSHOTS (default TMP/screenshots) and checked not blank
  ConsoleToken        a node whose status listens off loopback: refused without a token file;
                      with one, 401 without the token, the login form, then the console
  StaleNode           hmd-2 killed (SIGKILL): its card on the sky node's #site turns stale or
                      offline within 10 s, hmd-1's does not (last: it ends hmd-2)

Needs Debian's chromium, chromium-driver, python3-selenium and python3-pil
(scripts/install-deps.sh), hence /usr/bin/python3 rather than whatever python3 is first on PATH.
"""

import ctypes
import json
import math
import os
import pwd
import re
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import time
import types
import unittest
import urllib.error
import urllib.parse
import urllib.request

BROWSER_WAIT_S = 20      # a page load, its first two status updates, an image
FIXTURE_WAIT_S = 60      # every node up and heard
STALE_WAIT_S = 10        # a killed node's card turns stale or offline
PLANES = {"ground", "wall", "roof"}   # the sample site's
TABLET = (1024, 768)
PHONE = (390, 844)

F = types.SimpleNamespace(bin=None, src=None, tmp=None, procs={}, driver=None, reaper=None)


# --- small helpers -----------------------------------------------------------------------------

def wait_until(what, predicate, timeout, interval=0.1, check=None):
    """Polls predicate() until it returns something true; returns that. check() runs between
    polls and may raise (a process that died). Fails naming `what` and the last value or error."""
    deadline = time.monotonic() + timeout
    last = None
    while True:
        try:
            value = predicate()
            if value:
                return value
            last = value
        except Exception as e:  # noqa: BLE001 - anything a poll raises is "not yet"
            last = e
        if check:
            check()
        if time.monotonic() > deadline:
            raise AssertionError(f"timed out after {timeout} s waiting for {what} (last: {last!r})")
        time.sleep(interval)


def free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def port_open(port):
    try:
        with socket.create_connection(("127.0.0.1", port), 0.2):
            return True
    except OSError:
        return False


def http_get(url, headers=None, timeout=5):
    """(status code, body bytes) of a GET; an HTTP error status is returned, not raised."""
    request = urllib.request.Request(url, headers=headers or {})
    try:
        with urllib.request.urlopen(request, timeout=timeout) as response:
            return response.status, response.read()
    except urllib.error.HTTPError as e:
        return e.code, e.read()


def get_json(url, headers=None):
    code, body = http_get(url, headers)
    if code != 200:
        raise AssertionError(f"GET {url}: HTTP {code}: {body[:200]!r}")
    return json.loads(body)


def _die_with_parent():
    # The programs end with this test even when it is killed (a CTest timeout).
    ctypes.CDLL("libc.so.6", use_errno=True).prctl(1, signal.SIGKILL)  # PR_SET_PDEATHSIG


class Proc:
    """A program of the fixture, its stdout and stderr in TMP/NAME.log."""

    def __init__(self, name, args):
        self.name = name
        self.args = [str(a) for a in args]
        self.log_path = os.path.join(F.tmp, f"{name}.log")
        self.log = open(self.log_path, "wb")
        self.popen = subprocess.Popen(self.args, stdin=subprocess.DEVNULL, stdout=self.log,
                                      stderr=subprocess.STDOUT, preexec_fn=_die_with_parent)
        self.expect_exit = False

    def alive(self):
        return self.popen.poll() is None

    def tail(self, lines=25):
        self.log.flush()
        try:
            with open(self.log_path, "rb") as f:
                text = f.read().decode("utf-8", "replace")
        except OSError:
            return ""
        return "\n".join(text.splitlines()[-lines:])

    def check_alive(self):
        if not self.alive() and not self.expect_exit:
            raise AssertionError(f"{self.name} exited with status {self.popen.returncode}:\n"
                                 f"  {' '.join(self.args)}\n{self.tail()}")

    def stop(self, sig=signal.SIGTERM, timeout=15):
        if self.alive():
            self.popen.send_signal(sig)
            try:
                self.popen.wait(timeout)
            except subprocess.TimeoutExpired:
                self.popen.kill()
                self.popen.wait()
        self.log.close()


def start(name, args):
    proc = Proc(name, args)
    F.procs[name] = proc
    return proc


def check_procs():
    for proc in list(F.procs.values()):
        proc.check_alive()


def run_program(args, timeout=120):
    """Runs a program to its end; fails with its output when its exit status is not 0."""
    args = [str(a) for a in args]
    done = subprocess.run(args, stdin=subprocess.DEVNULL, capture_output=True, timeout=timeout,
                          preexec_fn=_die_with_parent)
    if done.returncode != 0:
        raise AssertionError(f"{' '.join(args)}: exit status {done.returncode}\n"
                             f"{done.stdout.decode(errors='replace')}{done.stderr.decode(errors='replace')}")


def replace_once(text, old, new, what):
    if text.count(old) != 1:
        raise AssertionError(f"{what}: expected one '{old.strip()}' in it, found {text.count(old)}"
                             " (has the file changed? update tests/console/console_test.py)")
    return text.replace(old, new)


# --- the fixture -------------------------------------------------------------------------------

def site_copy():
    """config/sample_site.yaml at 40x24 texels a plane (a bake is refused by the nodes unless it
    matches its site), its model named by absolute path. Under the same file name: a site's name
    is its file's, and it is the topic the nodes meet under."""
    what = os.path.join(F.src, "config/sample_site.yaml")
    with open(what) as f:
        text = f.read()
    text = replace_once(text, 'model: "../data/', f'model: "{F.src}/data/', what)
    text = replace_once(text, 'root: ".."', 'root: "/"', what)
    text, planes = re.subn(r"(?m)^(\s+resolution: )\[\d+, \d+\]", r"\g<1>[40, 24]", text)
    if planes == 0:
        raise AssertionError(f"{what}: no plane 'resolution: [W, H]' to replace")
    path = os.path.join(F.tmp, "sample_site.yaml")
    with open(path, "w") as f:
        f.write(text)
    return path


def hmd_config(node, extra_status=None):
    """config/site_hmd.yaml rewritten as scripts/demo_site.sh does (absolute paths, the node's
    name), on this test's bake and recording, the recording looping; `extra_status`: lines to put
    under `status:`."""
    src, tmp = F.src, F.tmp
    what = os.path.join(src, "config/site_hmd.yaml")
    with open(what) as f:
        text = f.read()
    text = re.sub(r"(?m)^root: .*$", "root: /", text)
    text = re.sub(r"(?m)^site: .*$", f"site: {F.site}", text)
    text = re.sub(r"(?m)^bake: .*$", f"bake: {tmp}/bake", text)
    text = replace_once(text, "\n  calibration: ", f"\n  calibration: {src}/config/", what)
    text = re.sub(r"(?m)^    path: \.\./build/demo/camera\s*$",
                  f"    path: {tmp}/camera\n    loop: true", text)
    if f"path: {tmp}/camera" not in text:
        raise AssertionError(f"{what}: no camera source path ../build/demo/camera to replace")
    text = replace_once(text, "  csv: ../build/demo/camera/poses.csv", f"  csv: {tmp}/camera/poses.csv", what)
    text = re.sub(r"(?m)^(    node: )hmd-1\b", rf"\g<1>{node}", text)
    if f"node: {node}" not in text:
        raise AssertionError(f"{what}: no 'node: hmd-1' to rename")
    if extra_status:
        lines = "".join(f"  {line}\n" for line in extra_status)
        if re.search(r"(?m)^status:\s*$", text):
            text = re.sub(r"(?m)^status:\s*$", "status:\n" + lines.rstrip("\n"), text, count=1)
        else:
            text += "status:\n" + lines
    path = os.path.join(tmp, f"{node}.yaml")
    with open(path, "w") as f:
        f.write(text)
    return path


def sky_config():
    """config/site_sky.yaml's structure on this test's bake: a clear day from 08:00 at Nara, a
    sky every 30 s of sky time, 60 times real time (two skies a second, the sun moving about a
    tenth of a degree between skies), with no end."""
    src = F.src
    text = f"""# config/site_sky.yaml for tests/console/console_test.py
root: /
site: {F.site}
bake: {F.tmp}/bake
sky:
  calibration: {src}/config/sky_camera.yaml
  source:
    kind: sky-sim
    calibration: {src}/config/sky_camera.yaml
    sky: clear
    start: 2026-06-21T08:00:00+09:00
    every: 30s
    frames: 0
    latitude: 34.69
    longitude: 135.80
    realtime: 60
  rate: 0
  sun: auto
link:
  broker: 127.0.0.1:1883
  node: sky
"""
    path = os.path.join(F.tmp, "sky.yaml")
    with open(path, "w") as f:
        f.write(text)
    return path


def setUpModule():  # noqa: N802 - unittest's name
    t0 = time.monotonic()
    F.tmp = tempfile.mkdtemp(prefix="skylit-console-")
    unittest.addModuleCleanup(tear_down_fixture)
    b, s, t = F.bin, F.src, F.tmp
    for program in ("skylit-bake", "skylit-camera-sim", "skylit-sky-node", "skylit-live"):
        if not os.access(os.path.join(b, program), os.X_OK):
            raise AssertionError(f"no {program} in {b}: build it first")

    F.site = site_copy()
    run_program([f"{b}/skylit-bake", F.site, "-o", f"{t}/bake",
                 "--resolution", "40x24", "-q"])
    run_program([f"{b}/skylit-camera-sim", "--calib", f"{s}/config/hmd_camera.yaml", "-o", f"{t}/camera",
                 "--frames", "30", "--sweep", "50", "--start-azimuth", "-120", "-q"])
    t_inputs = time.monotonic()

    F.broker_port = free_port()
    with open(f"{t}/mosquitto.conf", "w") as f:
        # `user`: the one running the test, so that a mosquitto started as root keeps its
        # credentials, and with them its parent-death signal.
        f.write(f"listener {F.broker_port} 127.0.0.1\nallow_anonymous true\npersistence false\n"
                f"user {pwd.getpwuid(os.getuid()).pw_name}\n")
    broker = start("mosquitto", ["/usr/sbin/mosquitto", "-c", f"{t}/mosquitto.conf"])
    wait_until(f"mosquitto on 127.0.0.1:{F.broker_port}", lambda: port_open(F.broker_port), 10,
               check=broker.check_alive)
    broker_arg = f"127.0.0.1:{F.broker_port}"

    F.sky_port = free_port()
    F.sky_url = f"http://127.0.0.1:{F.sky_port}"
    start("sky", [f"{b}/skylit-sky-node", sky_config(), "--broker", broker_arg,
                  "--status", f"127.0.0.1:{F.sky_port}", "-q"])
    F.hmd_urls = {}
    for node in ("hmd-1", "hmd-2"):
        port = free_port()
        F.hmd_urls[node] = f"http://127.0.0.1:{port}"
        start(node, [f"{b}/skylit-live", hmd_config(node), "--headless", "--broker", broker_arg,
                     "--status", f"127.0.0.1:{port}", "-q"])

    def everything_up():
        for node, url in F.hmd_urls.items():
            if get_json(f"{url}/status").get("state") != "running":
                return False
        heard = {n.get("node") for n in get_json(f"{F.sky_url}/site").get("nodes", [])
                 if n.get("state") == "running"}
        return heard >= set(F.hmd_urls)
    wait_until("hmd-1 and hmd-2 running, and both running in the sky node's /site", everything_up,
               FIXTURE_WAIT_S, interval=0.25, check=check_procs)
    F.fixture_s = time.monotonic() - t0
    print(f"\nconsole_test: fixture up in {F.fixture_s:.1f} s (bake and recording {t_inputs - t0:.1f} s); "
          f"sky node {F.sky_url}, hmd-1 {F.hmd_urls['hmd-1']}, hmd-2 {F.hmd_urls['hmd-2']}, folder {t}",
          file=sys.stderr, flush=True)


def tear_down_fixture():
    errors = []
    if F.driver is not None:
        try:
            F.driver.quit()
        except Exception as e:  # noqa: BLE001
            errors.append(f"browser: {e}")
        F.driver = None
    if F.reaper is not None:  # what is left of the browser's process group
        F.reaper.stdin.close()
        F.reaper.wait(10)
        F.reaper = None
    for name in reversed(list(F.procs)):  # the HMD nodes and the sky node before the broker
        try:
            F.procs[name].stop()
        except Exception as e:  # noqa: BLE001
            errors.append(f"{name}: {e}")
    F.procs.clear()
    if F.tmp:
        if os.environ.get("SKYLIT_CONSOLE_KEEP") == "1":
            print(f"console_test: kept {F.tmp}", file=sys.stderr)
        else:
            shutil.rmtree(F.tmp, ignore_errors=True)
    if errors:
        raise RuntimeError("; ".join(errors))


# --- the browser -------------------------------------------------------------------------------

def browser():
    """The module's one Chromium, started on first use."""
    if F.driver is None:
        from selenium import webdriver
        from selenium.webdriver.chrome.service import Service
        options = webdriver.ChromeOptions()
        options.binary_location = "/usr/bin/chromium"
        for arg in ("--headless=new", "--no-sandbox", "--disable-gpu", "--disable-dev-shm-usage",
                    f"--window-size={TABLET[0]},{TABLET[1]}", "--hide-scrollbars",
                    f"--user-data-dir={os.path.join(F.tmp, 'chromium')}"):
            options.add_argument(arg)
        options.set_capability("goog:loggingPrefs", {"browser": "ALL"})
        # chromedriver and Chromium in a process group of their own, which a reaper ends when
        # this test ends, however it ends (Chromium outlives a killed chromedriver).
        service = Service("/usr/bin/chromedriver", log_path=os.path.join(F.tmp, "chromedriver.log"),
                          popen_kw={"start_new_session": True})
        F.driver = webdriver.Chrome(service=service, options=options)
        F.reaper = subprocess.Popen(
            [sys.executable, "-c", "import os, signal, sys\nsys.stdin.buffer.read()\n"
             "try: os.killpg(int(sys.argv[1]), signal.SIGKILL)\nexcept OSError: pass",
             str(os.getpgid(service.process.pid))], stdin=subprocess.PIPE, start_new_session=True)
        F.driver.set_page_load_timeout(BROWSER_WAIT_S)
        set_viewport(*TABLET)
    return F.driver


def set_viewport(width, height):
    """Sizes the window so that the page's viewport is width x height CSS pixels."""
    d = F.driver
    d.set_window_size(width, height)
    inner = d.execute_script("return [window.innerWidth, window.innerHeight]")
    if inner != [width, height]:
        d.set_window_size(2 * width - inner[0], 2 * height - inner[1])


def js_errors():
    """The SEVERE entries of the browser's console since the last call (a missing favicon aside)."""
    return [e["message"] for e in F.driver.get_log("browser")
            if e.get("level") == "SEVERE" and "favicon.ico" not in e.get("message", "")]


def updates():
    value = F.driver.execute_script("return document.body ? document.body.dataset.updates : null")
    try:
        return int(value)
    except (TypeError, ValueError):
        return -1


def load_view(base, view):
    """A fresh load of BASE/#VIEW; waits for the view's section shown and two status updates."""
    code, body = http_get(f"{base}/")
    if code != 200 or b"<" not in body:
        raise AssertionError(f"GET {base}/: HTTP {code}, not the console page: {body[:120]!r}")
    d = browser()
    d.get("about:blank")
    js_errors()  # drop what came before
    d.get(f"{base}/#{view}")
    show_view(view, navigate=False)


def show_view(view, navigate=True):
    d = F.driver
    if navigate:
        d.execute_script("location.hash = arguments[0]", view)
    wait_until(f"<section id='view-{view}'> shown at {d.current_url}",
               lambda: d.execute_script(
                   "const s = document.getElementById(arguments[0]);"
                   "return s !== null && s.getClientRects().length > 0"
                   " && getComputedStyle(s).visibility !== 'hidden';", f"view-{view}"),
               BROWSER_WAIT_S)
    wait_until(f"document.body.dataset.updates >= 2 at {d.current_url}", lambda: updates() >= 2,
               BROWSER_WAIT_S)


def wait_images_loaded(selector):
    """Every img matching selector (at least one) has loaded: naturalWidth > 0."""
    d = F.driver

    def loaded():
        return d.execute_script(
            "const imgs = [...document.querySelectorAll(arguments[0])];"
            "imgs.forEach(i => { if (i.loading === 'lazy') i.scrollIntoView({block: 'nearest'}); });"
            "return imgs.length > 0 && imgs.every(i => i.complete && i.naturalWidth > 0);", selector)
    wait_until(f"images {selector} loaded (naturalWidth > 0)", loaded, BROWSER_WAIT_S)
    return d.execute_script("return document.querySelectorAll(arguments[0]).length", selector)


PAGE_VALUES_JS = """
const text = (sel) => { const e = document.querySelector(sel); return e ? e.textContent.trim() : null; };
return {
  updates: document.body.dataset.updates,
  sun_elevation: text('#view-sky [data-field="sun-elevation"]'),
  state: text('#view-sky [data-field="state"]'),
  frame_rate: text('#view-hmd [data-field="frame-rate"]'),
  opacity: text('#view-hmd [data-field="opacity"]'),
  flags: document.querySelector('#flags') === null ? null :
         [...document.querySelectorAll('#flags li[data-flag]')].map(li => li.dataset.flag),
  cards: [...document.querySelectorAll('#view-site article.node-card')].map(a => ({
    node: a.dataset.node,
    stale: a.classList.contains('stale'),
    frame_rate: (a.querySelector('[data-field="frame-rate"]') || {textContent: null}).textContent,
    state: (a.querySelector('[data-field="state"]') || {textContent: ''}).textContent.trim(),
  })),
};
"""


def page_values():
    return F.driver.execute_script(PAGE_VALUES_JS)


def number(text, decimals, what):
    """The value of a field shown with `decimals` decimals."""
    if text is None:
        raise AssertionError(f"{what}: no such element")
    if not re.fullmatch(rf"-?\d+\.\d{{{decimals}}}", text.strip()):
        raise AssertionError(f"{what}: '{text}' is not a number with {decimals} decimal(s)")
    return float(text)


def close(page, truth, tolerance):
    return abs(page - truth) <= tolerance


def sun_elevation(status):
    """sky.sun.elevation_deg of a /status, None when it has no sun (sky.sun null, false or
    absent); fails when it says there is a sun without giving its elevation."""
    sun = (status.get("sky") or {}).get("sun")
    if sun is None or sun is False:
        return None
    if not isinstance(sun, dict) or not isinstance(sun.get("elevation_deg"), (int, float)):
        raise AssertionError(f"/status has a sun but no sky.sun.elevation_deg (sky.sun: {sun!r})")
    return sun["elevation_deg"]


def compare_sky(page, status):
    problems = []
    try:
        truth = sun_elevation(status)
    except AssertionError as e:
        return [str(e)]
    shown = page["sun_elevation"]
    if truth is None:
        if shown != "—":
            problems.append(f"sun elevation: page '{shown}', /status has no sun (expected '—')")
    else:
        try:
            if not close(number(shown, 1, "sun-elevation"), truth, 0.5):
                problems.append(f"sun elevation: page {shown}, /status {truth:.2f} (tolerance 0.5°)")
        except AssertionError as e:
            problems.append(str(e))
    if page["state"] != status.get("state"):
        problems.append(f"state: page {page['state']!r}, /status {status.get('state')!r}")
    if page["flags"] is None:
        problems.append("no <ul id='flags'>")
    elif set(page["flags"]) != set(status.get("flags", [])):
        problems.append(f"flags: page {sorted(page['flags'])}, /status {sorted(status.get('flags', []))}")
    return problems


def frame_rate_tolerance(truth):
    return max(0.1 * truth, 0.5)


def compare_hmd(page, status):
    problems = []
    truth = status.get("frame_rate")
    try:
        shown = number(page["frame_rate"], 1, "frame-rate")
        if not isinstance(truth, (int, float)) or not close(shown, truth, frame_rate_tolerance(truth)):
            problems.append(f"frame rate: page {page['frame_rate']}, /status {truth}")
    except AssertionError as e:
        problems.append(str(e))
    try:
        number(page["opacity"], 2, "opacity")
        if isinstance(status.get("opacity"), (int, float)) and \
                not close(float(page["opacity"]), status["opacity"], 0.01):
            problems.append(f"opacity: page {page['opacity']}, /status {status['opacity']}")
    except AssertionError as e:
        problems.append(str(e))
    return problems


def compare_site(page, site):
    problems = []
    nodes = {n["node"]: n for n in site.get("nodes", [])}
    cards = {c["node"]: c for c in page["cards"]}
    if len(cards) != len(page["cards"]):
        problems.append(f"cards: a node twice in {[c['node'] for c in page['cards']]}")
    if set(cards) != set(nodes):
        problems.append(f"cards: page {sorted(cards)}, /site {sorted(nodes)}")
    for name in set(cards) & set(nodes):
        card, node = cards[name], nodes[name]
        stale = node.get("seconds_since_heard", 0) > 3
        if card["stale"] != stale:
            problems.append(f"{name}: card stale {card['stale']}, /site seconds_since_heard "
                            f"{node.get('seconds_since_heard')}")
        truth = node.get("frame_rate")
        try:
            shown = number(card["frame_rate"], 1, f"{name}'s card frame-rate")
            if not isinstance(truth, (int, float)) or not close(shown, truth, frame_rate_tolerance(truth)):
                problems.append(f"{name}: card frame rate {card['frame_rate']}, /site {truth}")
        except AssertionError as e:
            problems.append(str(e))
    return problems


def agree(test, fetch, compare, what):
    """The page's values against /status (or /site) fetched right after them; when they differ,
    once more after the page's next status update (they may have changed in between)."""
    page, truth = page_values(), fetch()
    problems = compare(page, truth)
    if problems:
        seen = updates()
        wait_until("the page's next status update", lambda: updates() > seen, 5)
        page, truth = page_values(), fetch()
        problems = compare(page, truth)
    test.assertEqual(problems, [], f"{what}: the page and the server disagree (read twice)")


def bake_planes():
    with open(os.path.join(F.tmp, "bake/manifest.json")) as f:
        return {p["name"] for p in json.load(f)["planes"]}


# --- the tests ---------------------------------------------------------------------------------

class FixtureCheck(unittest.TestCase):
    """The fixture over HTTP, without a browser: what the console shows comes from here."""

    def test_nodes_and_site(self):
        for node, url in F.hmd_urls.items():
            status = get_json(f"{url}/status")
            self.assertEqual(status.get("state"), "running", node)
            self.assertIsInstance(status.get("frame_rate"), (int, float), node)
            self.assertIsInstance(status.get("flags"), list, node)
            self.assertIsNotNone(sun_elevation(status), f"{node}: no sky.sun.elevation_deg in /status")
        sky = get_json(f"{F.sky_url}/status")
        self.assertEqual(sky.get("state"), "running", "the sky node")
        self.assertTrue(sky.get("sky", {}).get("sun"), "the sky node: no sun in the clear morning sky")
        site = get_json(f"{F.sky_url}/site")
        self.assertEqual({n["node"] for n in site["nodes"]}, set(F.hmd_urls))
        for n in site["nodes"]:
            self.assertLess(n["seconds_since_heard"], 3, n["node"])
        self.assertEqual(bake_planes(), PLANES)
        for url in (F.sky_url, *F.hmd_urls.values()):
            code, body = http_get(f"{url}/sky.jpg")
            self.assertEqual((code, body[:2]), (200, b"\xff\xd8"), f"{url}/sky.jpg")


class ConsoleViews(unittest.TestCase):
    """Each view loads without a JavaScript error, with its images, showing what /status says."""

    def open(self, base, view):
        load_view(base, view)
        self.addCleanup(lambda: self.assertEqual(js_errors(), [], f"JavaScript errors at {base}/#{view}"))

    def check_sky_view(self, base):
        self.open(base, "sky")
        wait_images_loaded("#sky-image")
        wait_images_loaded("#view-sky img")
        agree(self, lambda: get_json(f"{base}/status"), compare_sky, f"{base}/#sky")

    def check_bake_view(self, base):
        self.open(base, "bake")
        rows = F.driver.execute_script(
            "return [...document.querySelectorAll('#bake-planes tr[data-plane]')].map(r => r.dataset.plane)")
        self.assertEqual(sorted(rows), sorted(bake_planes()), "#bake-planes rows against the bake's planes")
        count = wait_images_loaded("#view-bake img.preview")
        self.assertEqual(count, len(rows), "one img.preview per plane")

    def test_hmd_sky(self):
        self.check_sky_view(F.hmd_urls["hmd-1"])

    def test_hmd_hmd(self):
        base = F.hmd_urls["hmd-1"]
        self.open(base, "hmd")
        wait_images_loaded("#frame-image")
        agree(self, lambda: get_json(f"{base}/status"), compare_hmd, f"{base}/#hmd")

    def test_hmd_bake(self):
        self.check_bake_view(F.hmd_urls["hmd-1"])

    def test_hmd_tabs(self):
        """An HMD node's console has the #sky, #hmd and #bake tabs and no #site tab shown."""
        base = F.hmd_urls["hmd-1"]
        self.open(base, "sky")
        for view in ("sky", "hmd", "bake"):
            href = F.driver.execute_script(
                "const a = document.getElementById(arguments[0]); return a && a.getAttribute('href')",
                f"tab-{view}")
            self.assertEqual(href, f"#{view}", f"<a id='tab-{view}'>")
        site_tab_shown = F.driver.execute_script(
            "const a = document.getElementById('tab-site'); return a !== null && a.getClientRects().length > 0")
        self.assertFalse(site_tab_shown, "an HMD node's console shows the #site tab")

    def test_keyboard_alone_moves_between_views(self):
        """From the page's top, Tab reaches the view tabs in order and Enter opens one."""
        from selenium.webdriver.common.keys import Keys
        base = F.hmd_urls["hmd-1"]
        self.open(base, "sky")
        body = F.driver.find_element("tag name", "body")
        reached = []
        for _ in range(6):
            body = F.driver.switch_to.active_element
            body.send_keys(Keys.TAB)
            reached.append(F.driver.execute_script("return document.activeElement.id"))
            if reached[-1] == "tab-hmd":
                break
        self.assertIn("tab-hmd", reached, f"Tab from the top reached {reached}, never the HMD tab")
        self.assertNotIn("tab-site", reached, "Tab reached the hidden #site tab")
        F.driver.switch_to.active_element.send_keys(Keys.ENTER)
        show_view("hmd", navigate=False)
        outline = F.driver.execute_script("return getComputedStyle(document.activeElement).outlineStyle")
        self.assertNotEqual(outline, "none", "the focused tab shows no focus outline")

    def test_sky_node_site(self):
        base = F.sky_url
        self.open(base, "site")
        agree(self, lambda: get_json(f"{base}/site"), compare_site, f"{base}/#site")

    def test_sky_node_sky(self):
        self.check_sky_view(F.sky_url)

    def test_sky_node_bake(self):
        self.check_bake_view(F.sky_url)


def screenshot_dir():
    folder = os.environ.get("SKYLIT_CONSOLE_SCREENSHOTS") or os.path.join(F.tmp, "screenshots")
    os.makedirs(folder, exist_ok=True)
    return folder


class ConsoleScreenshots(unittest.TestCase):
    """Each view at tablet and phone sizes, saved and checked not blank."""

    def shoot(self, name, base, views):
        from PIL import Image, ImageStat
        folder = screenshot_dir()
        d = browser()
        for size_name, size in (("tablet", TABLET), ("phone", PHONE)):
            set_viewport(*size)
            load_view(base, views[0])
            for view in views:
                with self.subTest(console=name, view=view, size=size_name):
                    show_view(view)
                    images = d.execute_script(
                        f"return document.querySelectorAll('#view-{view} img').length")
                    if images:
                        wait_images_loaded(f"#view-{view} img")
                    d.execute_script("window.scrollTo(0, 0)")
                    sky_shown = d.execute_script(
                        "const i = document.getElementById('sky-image');"
                        "return i !== null && i.getClientRects().length > 0 && i.naturalWidth > 0")
                    if sky_shown:  # the sky image in the viewport, for its region's check
                        d.execute_script(
                            "const i = document.getElementById('sky-image'); const r = i.getBoundingClientRect();"
                            "if (r.top < 0 || r.bottom > innerHeight) i.scrollIntoView({block: 'center'});")
                    path = os.path.join(folder, f"{name}-{view}-{size_name}.png")
                    self.assertTrue(d.save_screenshot(path), path)
                    with Image.open(path) as shot:
                        rgb = shot.convert("RGB")
                    if rgb.getcolors(maxcolors=15) is not None:  # None: more than 15 colours
                        self.fail(f"{path}: {len(rgb.getcolors(maxcolors=15))} colours: blank?")
                    if sky_shown:
                        r, dpr = d.execute_script(
                            "const r = document.getElementById('sky-image').getBoundingClientRect();"
                            "return [[r.left, r.top, r.right, r.bottom], window.devicePixelRatio]")
                        box = [max(0, math.floor(r[0] * dpr)), max(0, math.floor(r[1] * dpr)),
                               min(rgb.width, math.ceil(r[2] * dpr)), min(rgb.height, math.ceil(r[3] * dpr))]
                        self.assertTrue(box[2] - box[0] >= 8 and box[3] - box[1] >= 8,
                                        f"{path}: the sky image is not in the viewport ({r}, dpr {dpr})")
                        spread = ImageStat.Stat(rgb.crop(box)).stddev
                        self.assertGreater(max(spread), 8, f"{path}: the sky image's region {box} is flat "
                                                          f"(standard deviation {spread})")
                    self.assertEqual(js_errors(), [], f"JavaScript errors at {base}/#{view}, {size_name}")
        set_viewport(*TABLET)

    @classmethod
    def tearDownClass(cls):
        print(f"console_test: screenshots in {screenshot_dir()}"
              + ("" if os.environ.get("SKYLIT_CONSOLE_SCREENSHOTS") or os.environ.get("SKYLIT_CONSOLE_KEEP") == "1"
                 else " (removed at the end: set SKYLIT_CONSOLE_SCREENSHOTS=DIR or SKYLIT_CONSOLE_KEEP=1)"),
              file=sys.stderr)

    def test_hmd_views(self):
        self.shoot("hmd-1", F.hmd_urls["hmd-1"], ["sky", "hmd", "bake"])

    def test_sky_node_views(self):
        self.shoot("sky-node", F.sky_url, ["site", "sky", "bake"])


class ConsoleToken(unittest.TestCase):
    """A status address off loopback needs status.token_file (or allow_unauthenticated)."""

    NODE = "hmd-token"

    def test_off_loopback_needs_a_token(self):
        broker = f"127.0.0.1:{F.broker_port}"
        live = os.path.join(F.bin, "skylit-live")

        # Without a token file: refused, exit status 2, naming status.token_file.
        config = hmd_config(self.NODE)
        port = free_port()
        proc = start("token-refused", [live, config, "--headless", "--broker", broker,
                                       "--status", f"0.0.0.0:{port}", "-q"])
        proc.expect_exit = True
        try:
            proc.popen.wait(30)
        except subprocess.TimeoutExpired:
            proc.stop()
            self.fail(f"skylit-live with --status 0.0.0.0:{port} and no status.token_file started "
                      f"(expected exit status 2):\n{proc.tail()}")
        message = proc.tail()
        self.assertEqual(proc.popen.returncode, 2, message)
        self.assertIn("token_file", message)
        proc.stop()
        del F.procs["token-refused"]

        # With a token file (an installer's config: status.listen off loopback and
        # status.token_file): 401 without the token, 200 with it, over loopback too.
        token = "c0nsole-test-" + os.urandom(8).hex()
        token_path = os.path.join(F.tmp, "token")
        with open(token_path, "w") as f:
            f.write(token + "\n")
        port = free_port()
        config = hmd_config(self.NODE, [f"listen: 0.0.0.0:{port}", f"token_file: {token_path}"])
        base = f"http://127.0.0.1:{port}"
        node = start(self.NODE, [live, config, "--headless", "--broker", broker, "-q"])
        self.addCleanup(lambda: (node.stop(), F.procs.pop(self.NODE, None)))
        wait_until(f"{self.NODE}'s status server on port {port}", lambda: port_open(port), FIXTURE_WAIT_S,
                   interval=0.2, check=node.check_alive)
        for path in ("/status", "/metrics", "/sky.jpg"):
            code, _ = http_get(base + path)
            self.assertEqual(code, 401, f"GET {path} without the token")
        code, body = http_get(base + "/status", {"Authorization": f"Bearer {token}"})
        self.assertEqual(code, 200, f"GET /status with Authorization: Bearer: {body[:200]!r}")
        self.assertIn("state", json.loads(body))
        code, _ = http_get(base + "/status", {"Authorization": "Bearer not-the-token"})
        self.assertEqual(code, 401, "GET /status with a wrong token")
        code, _ = http_get(base + "/status", {"Cookie": f"skylit_token={token}"})
        self.assertEqual(code, 200, "GET /status with the cookie skylit_token")

        # In the browser, once the node runs (the login is under test here, not a console
        # opened while the node starts): the login form, then the console.
        wait_until(f"{self.NODE} running", lambda: get_json(base + "/status", {"Authorization": f"Bearer {token}"})
                   .get("state") == "running", FIXTURE_WAIT_S, interval=0.25, check=node.check_alive)
        from selenium.webdriver.common.by import By
        from selenium.webdriver.common.keys import Keys
        d = browser()
        d.delete_all_cookies()
        self.addCleanup(d.delete_all_cookies)
        d.get(base + "/")
        field = wait_until("the login form <form id='login'> with <input name='token'>",
                           lambda: d.find_element(By.CSS_SELECTOR, "form#login input[name='token']"),
                           BROWSER_WAIT_S)
        js_errors()  # the login page's own console is not judged
        field.send_keys(token + Keys.ENTER)
        wait_until("the console after logging in (no login form, body data-updates >= 2)",
                   lambda: not d.find_elements(By.CSS_SELECTOR, "form#login") and updates() >= 2,
                   BROWSER_WAIT_S)
        self.assertEqual(urllib.parse.urlsplit(d.current_url).path, "/", d.current_url)
        self.assertIsNotNone(d.get_cookie("skylit_token"), "no skylit_token cookie after logging in")
        self.assertEqual(js_errors(), [], "JavaScript errors on the console after logging in")


class StaleNode(unittest.TestCase):
    """hmd-2 killed: the sky node's #site marks its card; hmd-1's stays fresh. Ends hmd-2."""

    def test_killed_node_goes_stale(self):
        load_view(F.sky_url, "site")
        self.addCleanup(lambda: self.assertEqual(js_errors(), [], "JavaScript errors on the sky node's #site"))
        cards = {c["node"]: c for c in page_values()["cards"]}
        self.assertIn("hmd-2", cards)
        self.assertFalse(cards["hmd-2"]["stale"], "hmd-2's card is stale before it was killed")
        victim = F.procs["hmd-2"]
        victim.expect_exit = True
        victim.popen.send_signal(signal.SIGKILL)
        victim.popen.wait(10)
        killed = time.monotonic()

        def marked():
            card = {c["node"]: c for c in page_values()["cards"]}.get("hmd-2")
            return card and (card["stale"] or "offline" in card["state"].lower())
        wait_until("hmd-2's card stale (or its state offline) on the sky node's #site", marked, STALE_WAIT_S,
                   interval=0.2)
        took = time.monotonic() - killed
        cards = {c["node"]: c for c in page_values()["cards"]}
        self.assertIn("hmd-1", cards)
        self.assertFalse(cards["hmd-1"]["stale"], "hmd-1's card turned stale too")
        self.assertNotIn("offline", cards["hmd-1"]["state"].lower(), "hmd-1's card reads offline")
        print(f"console_test: hmd-2's card marked {took:.1f} s after SIGKILL", file=sys.stderr)


def load_tests(loader, tests, pattern):
    """In this order: the stale node's test ends hmd-2, so it comes last."""
    suite = unittest.TestSuite()
    for case in (FixtureCheck, ConsoleViews, ConsoleScreenshots, ConsoleToken, StaleNode):
        suite.addTests(loader.loadTestsFromTestCase(case))
    return suite


def main():
    if len(sys.argv) < 3 or not os.path.isdir(sys.argv[1]) or not os.path.isdir(sys.argv[2]):
        print(__doc__.split("\n\n")[1], file=sys.stderr)
        sys.exit(2)
    F.bin, F.src = os.path.abspath(sys.argv[1]), os.path.abspath(sys.argv[2])
    # SIGTERM (a CTest timeout, a stopped make) stops the programs and removes the folder too;
    # SIGKILL leaves it to the programs' parent-death signal (_die_with_parent).
    def interrupted(signum, frame):
        raise KeyboardInterrupt(f"signal {signum}")
    signal.signal(signal.SIGTERM, interrupted)
    try:
        unittest.main(argv=[sys.argv[0], *sys.argv[3:]], verbosity=2)
    finally:
        unittest.case.doModuleCleanups()


if __name__ == "__main__":
    main()
