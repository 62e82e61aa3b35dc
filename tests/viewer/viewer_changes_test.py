#!/usr/bin/env python3
"""The web viewer's changes over time in a real browser (headless Chromium through Selenium)
against a real loci-server on loopback.

Robot 1 maps a `loci synth` room with loci-track. With the page open, robot 2 maps the same room
two days later (`loci synth --days-later 2 --moved A --absent B`, the mechanism of
tests/server/object_changes_test.cc and `loci bench changes`): one thing put elsewhere on its
support, one taken away. The page must then show the moved object once, at its new place, with
a ghost at its old place; the one taken away as a ghost labelled "(gone)", not counted among the
objects in the status line; the same after a reload (api/objects?include_removed=1). A click in
the middle of the time slider (a map time between the two visits) must put the moved object back
at its old place without a ghost and show the removed one solid; the End key goes back to now.
No console error. Screenshots (now and in the past, each whole and as a close-up of the
changed objects) are saved as test artefacts.

Every wait polls a real signal against a deadline. Exit code 77 (ctest: skipped) only when
Chromium or its driver is not installed.

usage: viewer_changes_test.py --bin BIN_DIR --viewer-dir DIR --work DIR --artifacts DIR
                              [--classes config/classes.yaml]
"""
import argparse
import base64
import json
import math
import os
import shutil
import subprocess
import sys

import yaml

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from viewer_browser_test import (SKIP, CHROMIUM, CHROMEDRIVER, Server, check_no_console_errors,  # noqa: E402
                                 fail, first_existing, log, start_browser, track, viewer,
                                 wait_until)

SEED = 3
OBJECTS = 8
FRAMES = 75        # per visit (2.5 s at 30 Hz, about 14 keyframes)
DAYS_LATER = 2     # the second visit's stamps start this much later
NEAR_M = 0.02      # a place drawn within this of the server's


def synth(bin_dir, out, extra=()):
    return subprocess.run([os.path.join(bin_dir, "loci"), "synth", "--out", out, "--seed",
                           str(SEED), "--frames", str(FRAMES), "--objects", str(OBJECTS), *extra],
                          stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)


def pick_changes(scene, classes_yaml):
    """Two things resting on furniture and holding nothing, of the classes the map forgets
    soonest (stays_days), as (moved candidates, removed) ground-truth objects."""
    with open(classes_yaml) as f:
        stays = yaml.safe_load(f)["stays_days"]
    with open(os.path.join(scene, "objects.json")) as f:
        objects = json.load(f)["objects"]
    supports = {o["on"] for o in objects if o["on"] is not None}
    movable = [o for o in objects if o["on"] is not None and o["id"] not in supports
               and not o["dynamic"] and o.get("confidence", "high") != "low"
               and o["class_name"] in stays]
    movable.sort(key=lambda o: (stays[o["class_name"]], o["id"]))
    if len(movable) < 2:
        fail(f"seed {SEED}: fewer than two movable objects in {objects}")
    return movable


def later_visit(bin_dir, scene, movable):
    """The second visit: one of `movable` put elsewhere (one whose new place fits), another
    taken away. Returns (moved, removed) ground-truth objects."""
    for moved in movable:
        removed = next(o for o in movable if o is not moved)
        r = synth(bin_dir, scene, ["--days-later", str(DAYS_LATER), "--moved", str(moved["id"]),
                                   "--absent", str(removed["id"])])
        if r.returncode == 0:
            return moved, removed
        log(f"cannot move #{moved['id']} ({moved['class_name']}): {r.stderr.strip()}")
    fail("no movable object can be put elsewhere")


def visit_span(scene):
    """First and last frame stamp (ns) of a synth sequence: the map times of its keyframes."""
    with open(os.path.join(scene, "rgb.txt")) as f:
        stamps = [line.split()[0] for line in f if line.strip() and not line.startswith("#")]
    def to_ns(text):
        whole, _, frac = text.partition(".")
        return int(whole) * 10**9 + int(frac.ljust(9, "0"))
    return to_ns(stamps[0]), to_ns(stamps[-1])


def near(a, b, tol=NEAR_M):
    return a is not None and math.dist((a["x"], a["y"], a["z"]), (b["x"], b["y"], b["z"])) <= tol


def removed_ns(o):
    return int(o.get("removedTNs") or 0)


def kinds(o):
    return [c.get("kind", "APPEARED") for c in o.get("history", [])]


def server_changes(server, moved_gt, removed_gt):
    """The server's moved object and the one found gone, of the ground truth's classes."""
    objects = server.get("api/objects?include_removed=1")["objects"]
    moved = [o for o in objects if "MOVED" in kinds(o) and not removed_ns(o)]
    gone = [o for o in objects if removed_ns(o)]
    if [o["className"] for o in moved] != [moved_gt["class_name"]]:
        return None
    if [o["className"] for o in gone] != [removed_gt["class_name"]]:
        return None
    return objects, moved[0], gone[0]


def page_object(driver, oid):
    found = [o for o in viewer(driver, "objects") if o["id"] == oid]
    return found[0] if len(found) == 1 else None


def label_text(driver, oid):
    return driver.execute_script(
        "const e = document.querySelector(`.label[data-object-id='${arguments[0]}']`);"
        "return e && e.style.display !== 'none' ? e.textContent : null;", oid)


def live_count(server_objects):
    return sum(1 for o in server_objects if o.get("confirmed") and not removed_ns(o))


def check_now(driver, server_objects, moved, gone, what):
    """At now: the page holds every server object once, the moved one at its new place with a
    ghost at its old place, the gone one a ghost labelled (gone) and left out of the count."""
    mid, gid = int(moved["id"]), int(gone["id"])
    old = next(c for c in moved["history"] if c.get("kind") == "MOVED")["fromM"]

    def shows():
        page = viewer(driver, "objects")
        if sorted(o["id"] for o in page) != sorted(int(o["id"]) for o in server_objects):
            return None
        m, g = page_object(driver, mid), page_object(driver, gid)
        ok = (m and m["shown"] and not m["gone"] and near(m["shownAt"], moved["centroidM"])
              and m["ghosts"] == 1 and near(m["ghostsAt"][0], old)
              and g and g["shown"] and g["gone"] and near(g["shownAt"], gone["centroidM"])
              and g["ghosts"] == 0)
        return (m, g) if ok else None
    m, g = wait_until(f"{what}: moved #{mid} with a ghost at its old place, #{gid} gone", shows, 30)
    others = [o for o in viewer(driver, "objects") if o["id"] not in (mid, gid)]
    if any(o["gone"] or o["ghosts"] for o in others):
        fail(f"{what}: other objects gone or moved on the page: {others}")
    twins = [o for o in others if o["className"] == moved["className"] and o["shown"]
             and near(o["shownAt"], moved["centroidM"], 0.15)]
    if twins:
        fail(f"{what}: the moved object is shown twice: #{mid} and {twins}")
    gone_label = wait_until(f"{what}: the gone object's label",
                            lambda: label_text(driver, gid), 10)
    if gone_label != f"{gone['className']} #{gid} (gone)":
        fail(f"{what}: label of the gone object is {gone_label!r}")
    status = driver.find_element("id", "status").text
    want = f"{live_count(server_objects)} objects"
    if want not in status or "1 gone" not in status:
        fail(f"{what}: status {status!r}, want '{want}' and '1 gone'")
    if viewer(driver, "timeLabel") != "now" or viewer(driver, "time") is not None:
        fail(f"{what}: the slider is not at now: {viewer(driver, 'timeLabel')}")
    log(f"{what}: moved {moved['className']} #{mid} at {m['shownAt']} with a ghost at "
        f"{m['ghostsAt'][0]}; {gone_label}; status {status!r}")


def screen_points(driver, ids):
    """Client pixels of the objects' centroids where the page draws them now."""
    return [p for p in (viewer(driver, f"screenPosition({i})") for i in ids) if p]


def save_shots(driver, artifacts, name, points):
    """The whole page as NAME.png and, around `points` (client pixels), a 2x close-up as
    NAME_zoom.png."""
    shot = os.path.join(artifacts, name + ".png")
    driver.save_screenshot(shot)
    size = driver.execute_script("return [innerWidth, innerHeight];")
    x0 = max(0, min(p["x"] for p in points) - 160)
    y0 = max(0, min(p["y"] for p in points) - 110)
    x1 = min(size[0], max(p["x"] for p in points) + 160)
    y1 = min(size[1], max(p["y"] for p in points) + 110)
    clip = {"x": x0, "y": y0, "width": x1 - x0, "height": y1 - y0, "scale": 2}
    data = driver.execute_cdp_cmd("Page.captureScreenshot", {"format": "png", "clip": clip})
    with open(os.path.join(artifacts, name + "_zoom.png"), "wb") as f:
        f.write(base64.b64decode(data["data"]))
    log(f"screenshots: {shot} and its close-up {name}_zoom.png")


def check_time_range(driver, server_objects):
    first = min(min([int(o["firstSeenNs"])] + [int(c["tNs"]) for c in o.get("history", [])[:1]])
                for o in server_objects)
    last = max([int(o.get("lastSeenNs", 0)) for o in server_objects] +
               [int(c.get("tNs", 0)) for o in server_objects for c in o.get("history", [])])
    got = viewer(driver, "timeRange")
    if got != {"minNs": str(first), "maxNs": str(last)}:
        fail(f"time range {got}, want {first}..{last}")
    return first, last


def check_past(driver, moved, gone, visit1, visit2, artifacts):
    """A click in the middle of the time slider: a map time between the visits."""
    from selenium.webdriver.common.action_chains import ActionChains
    from selenium.webdriver.common.keys import Keys
    mid, gid = int(moved["id"]), int(gone["id"])
    old = next(c for c in moved["history"] if c.get("kind") == "MOVED")["fromM"]
    first_visit_end, second_visit_start = visit_span(visit1)[1], visit_span(visit2)[0]
    slider = driver.find_element("id", "time")
    ActionChains(driver).move_to_element(slider).click().perform()
    t = wait_until("the slider to pick a time", lambda: viewer(driver, "time"), 10)
    if not first_visit_end < int(t) < second_visit_start:
        fail(f"slider time {t} not between the visits ({first_visit_end}, {second_visit_start})")
    label = viewer(driver, "timeLabel")
    if not label.endswith(" UTC)") or " before newest (" not in label:
        fail(f"slider label {label!r}")

    def past():
        m, g = page_object(driver, mid), page_object(driver, gid)
        ok = (m and m["shown"] and near(m["shownAt"], old) and m["ghosts"] == 0
              and g and g["shown"] and not g["gone"] and g["ghosts"] == 0)
        return (m, g) if ok else None
    m, g = wait_until(f"moved #{mid} at its old place and #{gid} solid at {label}", past, 10)
    text = label_text(driver, gid)
    if not text or "(gone)" in text:
        fail(f"label of #{gid} before its removal: {text!r}")
    if "1 gone" in driver.find_element("id", "status").text:
        fail("the status counts a gone object before its removal")
    log(f"at {label}: #{mid} at its old place {m['shownAt']}, #{gid} solid ({text})")
    old_place = screen_points(driver, [mid])
    save_shots(driver, artifacts, "viewer_changes_past", old_place + screen_points(driver, [gid]))
    slider.send_keys(Keys.END)
    wait_until("the End key to bring the slider back to now",
               lambda: viewer(driver, "timeLabel") == "now" and viewer(driver, "time") is None, 10)
    return old_place


def run(args, chromium, chromedriver):
    shutil.rmtree(args.work, ignore_errors=True)
    os.makedirs(args.work)
    os.makedirs(args.artifacts, exist_ok=True)
    visit1, visit2 = os.path.join(args.work, "visit1"), os.path.join(args.work, "visit2")
    if synth(args.bin, visit1).returncode != 0:
        fail("loci synth failed")
    moved_gt, removed_gt = later_visit(args.bin, visit2, pick_changes(visit1, args.classes))
    log(f"second visit: #{moved_gt['id']} ({moved_gt['class_name']}) moved, "
        f"#{removed_gt['id']} ({removed_gt['class_name']}) taken away")
    server = Server(args.bin, args.viewer_dir, args.work)  # robot2 placed where robot1 started
    driver = None
    try:
        track(args.bin, visit1, server, "robot1")
        server.wait_mapped()
        driver = start_browser(chromium, chromedriver)
        driver.get(server.url)
        wait_until("the viewer to load and go live",
                   lambda: viewer(driver, "ready") and viewer(driver, "live") == "live", 30)
        if any(o["gone"] or o["ghosts"] for o in viewer(driver, "objects")):
            fail(f"changes before the second visit: {viewer(driver, 'objects')}")
        track(args.bin, visit2, server, "robot2")
        server.wait_mapped()
        found = wait_until("the server to report the move and the removal",
                           lambda: server_changes(server, moved_gt, removed_gt), 30)
        objects, moved, gone = found
        check_now(driver, objects, moved, gone, "live events")
        log(f"{viewer(driver, 'eventsReceived')} object events reached the open page")
        driver.refresh()
        wait_until("the reloaded viewer to go live",
                   lambda: viewer(driver, "ready") and viewer(driver, "live") == "live", 30)
        check_now(driver, objects, moved, gone, "after a reload")
        check_time_range(driver, objects)
        old_place = check_past(driver, moved, gone, visit1, visit2, args.artifacts)
        check_now(driver, objects, moved, gone, "back at now")
        save_shots(driver, args.artifacts, "viewer_changes",
                   old_place + screen_points(driver, [int(moved["id"]), int(gone["id"])]))
        check_no_console_errors(driver)
    finally:
        if driver is not None:
            driver.quit()
        server.stop()
    log("viewer changes test ok")


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--bin", required=True, help="folder of loci-server, loci-track and loci")
    p.add_argument("--viewer-dir", required=True, help="the built viewer (share/loci/viewer)")
    p.add_argument("--work", required=True, help="scratch folder (emptied)")
    p.add_argument("--artifacts", required=True, help="where the screenshots go")
    p.add_argument("--classes", help="classes.yaml with stays_days (default: the source tree's)",
                   default=os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..",
                                        "config", "classes.yaml"))
    args = p.parse_args()
    chromium, chromedriver = first_existing(CHROMIUM), first_existing(CHROMEDRIVER)
    if chromium is None or chromedriver is None:
        print("SKIP: headless Chromium not installed (apt-get install chromium chromium-driver)")
        return SKIP
    run(args, chromium, chromedriver)
    return 0


if __name__ == "__main__":
    sys.exit(main())
