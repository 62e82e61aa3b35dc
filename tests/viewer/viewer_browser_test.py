#!/usr/bin/env python3
"""The web viewer in a real browser (headless Chromium through Selenium) against a real
loci-server on loopback.

Robot 1 streams a `loci synth` room with loci-track (ground-truth poses, synthetic detections);
the page must then hold exactly the server's objects (id and class), the cloud and robot 1's
trajectory, with no console error. A question highlights the objects of its answer and shows its
sentence; a click on an object opens its inspection panel. Then robot 2 streams a few keyframes
of another room while the page stays open: its new objects and trajectory must appear without a
reload, its candidates hidden until the 'candidates' box is ticked. A screenshot is saved as a
test artefact.

Every wait polls a real signal (the server's "listening on" line, its mapped-keyframe counter,
the page's window.lociViewer state) against a deadline. Exit code 77 (ctest: skipped) only when
Chromium or its driver is not installed.

usage: viewer_browser_test.py --bin BIN_DIR --viewer-dir DIR --work DIR --artifacts DIR
"""
import argparse
import json
import os
import queue
import shutil
import subprocess
import sys
import threading
import time
import urllib.parse
import urllib.error
import urllib.request

SKIP = 77
CHROMIUM = ["/usr/bin/chromium", "/usr/bin/chromium-browser"]
CHROMEDRIVER = ["/usr/bin/chromedriver"]


def log(msg):
    print(f"[viewer-test] {msg}", flush=True)


def fail(msg):
    log("FAIL: " + msg)
    sys.exit(1)


def first_existing(paths):
    return next((p for p in paths if os.path.exists(p)), None)


def wait_until(what, check, timeout_s, every_s=0.2):
    """Polls check() until it returns a truthy value; fails after timeout_s."""
    deadline = time.monotonic() + timeout_s
    while True:
        value = check()
        if value:
            return value
        if time.monotonic() > deadline:
            fail(f"timed out after {timeout_s} s waiting for {what}")
        time.sleep(every_s)


class Server:
    """loci-server on free loopback ports; ready at its 'listening on' and 'http on' lines and
    once /api/stats answers (503 while the server loads its map)."""

    def __init__(self, bin_dir, viewer_dir, work):
        self.log_path = os.path.join(work, "server.log")
        # robot2 streams another synthetic room from the same start: placed by config, as a
        # robot that place recognition cannot align (a different room) has to be.
        config = os.path.join(work, "server.yaml")
        with open(config, "w") as f:
            f.write("sessions:\n  robot2:\n    t_base_odom_m: [0, 0, 0]\n"
                    "    q_base_odom_wxyz: [1, 0, 0, 0]\n")
        self.proc = subprocess.Popen(
            [os.path.join(bin_dir, "loci-server"), "--listen", "127.0.0.1:0", "--http",
             "127.0.0.1:0", "--db", os.path.join(work, "map.db"), "--viewer-dir", viewer_dir,
             "--config", config, "--log-level", "warn"],
            stdout=subprocess.PIPE, stderr=open(self.log_path, "w"), text=True)
        self.lines = queue.Queue()  # stdout lines, None at EOF, read by a thread
        threading.Thread(target=self._pump, daemon=True).start()
        self.grpc = self._read_line("listening on ", 30)
        self.http = self._read_line("http on ", 10)
        self.url = f"http://{self.http}/"
        wait_until("the map to load", self._loaded, 60)

    def _loaded(self):
        try:
            self.get("api/stats")
            return True
        except urllib.error.HTTPError as e:
            if e.code != 503:
                raise
            return False

    def _pump(self):
        for line in self.proc.stdout:
            self.lines.put(line)
        self.lines.put(None)

    def _read_line(self, prefix, timeout_s):
        deadline = time.monotonic() + timeout_s
        while True:
            try:
                line = self.lines.get(timeout=max(0.0, deadline - time.monotonic()))
            except queue.Empty:
                fail(f"no '{prefix}' line from loci-server within {timeout_s} s")
            if line is None:
                fail("loci-server exited: " + open(self.log_path).read())
            if line.startswith(prefix):
                return line[len(prefix):].strip()

    def get(self, path):
        with urllib.request.urlopen(self.url + path.lstrip("/"), timeout=10) as r:
            return json.loads(r.read())

    def objects(self):
        return {int(o["id"]): o["className"] for o in self.get("api/objects")["objects"]}

    def wait_mapped(self, timeout_s=60):
        """Until every stored keyframe is integrated into the map."""
        def caught_up():
            s = self.get("api/stats")
            return int(s["keyframes"]) > 0 and s["mappedKeyframes"] == s["keyframes"]
        wait_until("the mapper to catch up", caught_up, timeout_s)

    def stop(self):
        self.proc.terminate()
        try:
            self.proc.wait(timeout=10)
        except subprocess.TimeoutExpired:
            self.proc.kill()


def synth(bin_dir, out, seed, frames):
    subprocess.run([os.path.join(bin_dir, "loci"), "synth", "--out", out, "--seed", str(seed),
                    "--frames", str(frames), "--objects", "8"],
                   check=True, stdout=subprocess.DEVNULL)


def track(bin_dir, scene, server, robot, max_frames=0):
    cmd = [os.path.join(bin_dir, "loci-track"), "--tum", scene, "--server", server.grpc,
           "--robot", robot, "--poses", os.path.join(scene, "groundtruth.txt"),
           "--detections", os.path.join(scene, "detections.jsonl"), "--no-progress",
           "--log-level", "warn"]
    if max_frames:
        cmd += ["--max-frames", str(max_frames)]
    subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL)


def start_browser(chromium, chromedriver):
    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service
    options = webdriver.ChromeOptions()
    options.binary_location = chromium
    for arg in ["--headless=new", "--no-sandbox", "--disable-dev-shm-usage",
                "--enable-unsafe-swiftshader", "--use-angle=swiftshader", "--window-size=1400,900",
                "--hide-scrollbars"]:
        options.add_argument(arg)
    options.set_capability("goog:loggingPrefs", {"browser": "ALL"})
    return webdriver.Chrome(service=Service(chromedriver), options=options)


def viewer(driver, expr):
    return driver.execute_script(f"return window.lociViewer && window.lociViewer.{expr};")


def check_no_console_errors(driver):
    errors = [e for e in driver.get_log("browser") if e["level"] == "SEVERE"]
    if errors:
        fail("console errors: " + json.dumps(errors, indent=1))
    page_errors = viewer(driver, "errors")
    if page_errors:
        fail("viewer errors: " + json.dumps(page_errors))


def page_objects(driver):
    """The page's live objects (found gone ones, drawn as ghosts, left out), id -> class."""
    return {o["id"]: o["className"] for o in viewer(driver, "objects") or [] if not o.get("gone")}


def check_scene_matches(driver, server, what):
    """The page shows exactly the server's objects, by id and class."""
    want = server.objects()
    if not want:
        fail(f"{what}: the server mapped no objects")
    wait_until(f"{what}: the page's objects to equal the server's {want}",
               lambda: page_objects(driver) == want, 30)
    log(f"{what}: {len(want)} objects on the page match the server: {sorted(want.items())}")
    return want


def check_question(driver, server, objects):
    """A question about a class the map holds once highlights that object and shows the answer."""
    classes = sorted(objects.values())
    single = next((c for c in classes if classes.count(c) == 1 and c != "dining table"), classes[0])
    question = f"where is the {single}"
    expected = server.get("api/ask?q=" + urllib.parse.quote(question))
    want_ids = sorted(int(o["id"]) for o in expected["objects"])
    if not want_ids:
        fail(f"'{question}': the server's answer names no object: {expected}")
    box = driver.find_element("id", "question")
    box.clear()
    box.send_keys(question)
    driver.find_element("css selector", "#ask-form button").click()
    wait_until(f"'{question}' to highlight {want_ids}",
               lambda: viewer(driver, "highlighted") == want_ids, 15)
    shown = driver.find_element("id", "answer").text
    if shown != expected["answer"]:
        fail(f"answer shown '{shown}', server says '{expected['answer']}'")
    marked = driver.execute_script(
        "return [...document.querySelectorAll('.label.highlight')].map(e => +e.dataset.objectId)"
        ".sort((a, b) => a - b);")
    if marked != want_ids:
        fail(f"highlighted labels {marked}, want {want_ids}")
    log(f"'{question}' -> '{shown}', highlighted {want_ids}")


def inspected(driver, oid):
    """The inspection panel's summary once it shows `oid`; page errors end the wait."""
    errors = viewer(driver, "errors")
    if errors:
        fail(f"viewer errors while inspecting #{oid}: {errors}")
    shown = viewer(driver, "inspected") or {}
    return shown if shown.get("id") == oid else None


def check_click_inspects(driver, objects):
    """A click on an object's centroid opens its panel with labels, robots and its own cloud."""
    from selenium.webdriver.common.action_chains import ActionChains
    canvas = driver.find_element("css selector", "#view canvas")
    rect = driver.execute_script("return arguments[0].getBoundingClientRect().toJSON();", canvas)
    for oid in sorted(objects):
        p = viewer(driver, f"screenPosition({oid})")
        if not p or not (80 < p["y"] < rect["height"] - 40 and 10 < p["x"] < rect["width"] - 400):
            continue
        ActionChains(driver).move_to_element_with_offset(
            canvas, p["x"] - rect["width"] / 2, p["y"] - rect["height"] / 2).click().perform()
        if viewer(driver, "selected") != oid:
            continue  # another object's box was in front
        shown = wait_until(f"the inspection panel of #{oid} (page errors: see below)",
                           lambda: inspected(driver, oid), 10)
        if shown["points"] <= 0 or not shown["labels"] or not shown["robots"]:
            fail(f"inspection panel of #{oid} incomplete: {shown}")
        if not driver.find_element("id", "inspect").is_displayed():
            fail("inspection panel hidden")
        log(f"clicked #{oid}: panel shows {shown}")
        return oid
    fail("no click on an object's centroid selected that object")


def check_live_update(driver, server, bin_dir, scene2, before):
    """Robot 2's keyframes add objects and a trajectory on the open page, without a reload."""
    driver.execute_script("window.__notReloaded = true;")
    events_before = viewer(driver, "eventsReceived")
    track(bin_dir, scene2, server, "robot2", max_frames=3)
    server.wait_mapped()
    now = check_scene_matches(driver, server, "after robot2")
    new_ids = sorted(set(now) - set(before))
    if not new_ids:
        fail(f"robot2's keyframes added no object (before {before}, after {now})")
    if not driver.execute_script("return window.__notReloaded === true;"):
        fail("the page reloaded")
    if viewer(driver, "eventsReceived") <= events_before:
        fail("no object event reached the page")
    wait_until("robot2's trajectory on the page",
               lambda: "robot2" in [r["robot"] for r in viewer(driver, "robots")], 10)
    log(f"live: new objects {[(i, now[i]) for i in new_ids]} and robot2's trajectory appeared")


def label_displayed(driver, oid):
    return driver.execute_script(
        "const e = document.querySelector(`.label[data-object-id='${arguments[0]}']`);"
        "return !!e && e.style.display !== 'none';", oid)


def check_candidates_toggle(driver, server):
    """Candidates (objects not confirmed yet) are hidden until the 'candidates' box is ticked.
    Robot 2's 3 frames (0.1 s) cannot confirm anything (fusion.confirm_min_span_s 0.5 s)."""
    confirmed = {int(o["id"]): bool(o.get("confirmed")) for o in server.get("api/objects")["objects"]}
    candidates = sorted(i for i, c in confirmed.items() if not c)
    if not candidates or all(not c for c in confirmed.values()):
        fail(f"want both confirmed objects and candidates on the server: {confirmed}")
    if viewer(driver, "showCandidates"):
        fail("candidates are shown before the box is ticked")

    def shown_is(want):
        page = {o["id"]: o["shown"] for o in viewer(driver, "objects") if not o.get("gone")}
        return page == want and all(label_displayed(driver, i) == s for i, s in want.items())
    wait_until(f"only the confirmed objects drawn (candidates {candidates} hidden)",
               lambda: shown_is(confirmed), 10)
    legend = driver.find_element("id", "legend").text
    driver.find_element("id", "show-candidates").click()
    wait_until("every object drawn once candidates are ticked",
               lambda: shown_is({i: True for i in confirmed}), 10)
    log(f"candidates {candidates} hidden until ticked, then drawn; legend before: {legend!r}")


def run(args, chromium, chromedriver):
    shutil.rmtree(args.work, ignore_errors=True)
    os.makedirs(args.work)
    os.makedirs(args.artifacts, exist_ok=True)
    scene1, scene2 = os.path.join(args.work, "room1"), os.path.join(args.work, "room2")
    synth(args.bin, scene1, seed=3, frames=75)  # 14 keyframes: the map frame settles (10)
    synth(args.bin, scene2, seed=11, frames=3)
    server = Server(args.bin, args.viewer_dir, args.work)
    driver = None
    try:
        track(args.bin, scene1, server, "robot1")
        server.wait_mapped()
        driver = start_browser(chromium, chromedriver)
        driver.get(server.url)
        wait_until("the viewer to load and go live",
                   lambda: viewer(driver, "ready") and viewer(driver, "live") == "live", 30)
        before = check_scene_matches(driver, server, "after robot1")
        if viewer(driver, "cloudPoints") <= 0:
            fail("no cloud points on the page")
        robots = viewer(driver, "robots")
        poses = len(server.get("api/trajectories")["trajectories"][0]["poses"])
        if [(r["robot"], r["poses"]) for r in robots] != [("robot1", poses)]:
            fail(f"page robots {robots}, server has robot1 with {poses} poses")
        check_live_update(driver, server, args.bin, scene2, before)
        check_candidates_toggle(driver, server)
        objects = server.objects()
        check_click_inspects(driver, objects)
        check_question(driver, server, objects)
        check_no_console_errors(driver)
        shot = os.path.join(args.artifacts, "viewer.png")
        driver.save_screenshot(shot)
        log(f"screenshot: {shot}")
    finally:
        if driver is not None:
            driver.quit()
        server.stop()
    log("viewer browser test ok")


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--bin", required=True, help="folder of loci-server, loci-track and loci")
    p.add_argument("--viewer-dir", required=True, help="the built viewer (share/loci/viewer)")
    p.add_argument("--work", required=True, help="scratch folder (emptied)")
    p.add_argument("--artifacts", required=True, help="where viewer.png goes")
    args = p.parse_args()
    chromium, chromedriver = first_existing(CHROMIUM), first_existing(CHROMEDRIVER)
    if chromium is None or chromedriver is None:
        print("SKIP: headless Chromium not installed (apt-get install chromium chromium-driver)")
        return SKIP
    run(args, chromium, chromedriver)
    return 0


if __name__ == "__main__":
    sys.exit(main())
