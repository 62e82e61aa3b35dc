#!/usr/bin/python3
"""Copy a TUM RGB-D folder with one ground-truth object's pixels removed from every frame.

usage: /usr/bin/python3 scripts/mask-object.py TUM_DIR OUT_DIR (--object ID | --pick)
           [--gt objects_gt.json] [--eval EVAL.json] [--grow-m 0.03] [--shift-s 86400]
           [--offset-ms 0] [--camera config/camera_tum_fr1.yaml] [--examples N]

The object is an axis-aligned box (`centroid_m`, `extent_m`) in the world frame of the folder's
groundtruth.txt (objects_gt.json format). For every depth frame, with the ground-truth pose
T_world_cam at the nearest stamp, the mask is:
  - the pixels whose back-projected depth lies inside the box grown by --grow-m,
  - plus the pixels without depth inside the box's projected silhouette that lie within a few
    pixels of those (the object's own depth holes: a dark or shiny surface),
  - dilated by 3 px (mixed pixels at the object's rim).
The masked depth is replaced by what lies behind the object: per pixel, the nearest of the
valid background depths found left, right, above and below on the mask's border ring that lies
behind the grown box along the pixel's ray, so the free space where the object stood is
observed; a pixel with no such background gets no depth (unobserved, not a made-up surface). Each RGB frame takes the mask of its nearest depth frame (depth is registered to
colour in TUM) and is filled with cv2.inpaint (Telea). Frames with an empty mask, and the folder's
other files, are symlinked.

Time: --shift-s adds that many seconds to every stamp of rgb.txt, depth.txt, groundtruth.txt and
accelerometer.txt (the file names stay), as the same room recorded that much later (default one
day: a robot coming back tomorrow). The map's existence belief is a function of map time, so a
replay with the first session's own stamps is not a later visit. 0 keeps the stamps.

Camera: fr1 intrinsics and lens distortion as loci-track uses them (config/camera_tum_fr1.yaml;
a camera.yaml in TUM_DIR, when present, as loci-track reads it first).

--pick chooses the object by a rule that names no instance: among the ground-truth objects of
confidence `high` that rest on another object (`on` set) and, when --eval gives the first
session's `loci eval objects --json` output, that the map matched, the one with the most
`visible_frames`. It prints the chosen id on stdout's last line as `object: ID CLASS`.
"""
import argparse
import json
import os
import shutil
import sys

import cv2
import numpy as np


def read_list(path):
    rows = []
    with open(path) as f:
        for line in f:
            s = line.strip()
            if not s or s.startswith('#'):
                continue
            rows.append(s.split())
    return rows


def read_camera(tum_dir, default_yaml):
    """fx fy cx cy, distortion (k1 k2 p1 p2 k3), depth scale: camera.yaml in the folder first."""
    import yaml  # Debian's python3-yaml
    path = os.path.join(tum_dir, 'camera.yaml')
    if not os.path.exists(path):
        path = default_yaml
    with open(path) as f:
        y = yaml.safe_load(f)
    cam = y.get('camera', y)
    k = np.array([[cam['fx'], 0, cam['cx']], [0, cam['fy'], cam['cy']], [0, 0, 1]], dtype=np.float64)
    dist = np.array(cam.get('distortion', [0, 0, 0, 0, 0]), dtype=np.float64)
    scale = float(y.get('depth_scale', 5000.0))
    return k, dist, int(cam.get('width', 640)), int(cam.get('height', 480)), scale, path


def quat_to_r(qx, qy, qz, qw):
    n = np.sqrt(qx * qx + qy * qy + qz * qz + qw * qw)
    x, y, z, w = qx / n, qy / n, qz / n, qw / n
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                     [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                     [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])


def pick_object(gt, eval_path):
    matched = None
    if eval_path:
        with open(eval_path) as f:
            ev = json.load(f)
        matched = set(gt_ids_matched(ev))
    cands = [o for o in gt['objects'] if o.get('confidence') == 'high' and o.get('on')
             and (matched is None or o['id'] in matched)]
    if not cands:
        sys.exit('mask-object: --pick found no high-confidence object resting on another'
                 + (' that the map matched' if matched is not None else ''))
    cands.sort(key=lambda o: (-int(o.get('visible_frames', 0)), o['id']))
    return cands[0]


def gt_ids_matched(ev):
    """Ground-truth ids that `loci eval objects --json` matched to a map object."""
    out = []
    for m in ev.get('matches', []):
        gid = m.get('gt_id', m.get('gt', m.get('truth_id')))
        if isinstance(gid, dict):
            gid = gid.get('id')
        if gid is not None:
            out.append(str(gid))
    return out


def pose_index(gt_rows, offset_s):
    t = np.array([float(r[0]) for r in gt_rows])
    poses = [(np.array([float(v) for v in r[1:4]]), quat_to_r(*[float(v) for v in r[4:8]]))
             for r in gt_rows]

    def at(stamp):
        i = int(np.argmin(np.abs(t - (stamp + offset_s))))
        return poses[i], abs(t[i] - (stamp + offset_s))
    return at


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument('tum_dir')
    ap.add_argument('out_dir')
    g = ap.add_mutually_exclusive_group(required=True)
    g.add_argument('--object', help='id of the object in the ground truth')
    g.add_argument('--pick', action='store_true', help='choose the object by the rule above')
    ap.add_argument('--gt', help='object ground truth (default TUM_DIR/objects_gt.json)')
    ap.add_argument('--eval', help="first session's `loci eval objects --json` output (for --pick)")
    ap.add_argument('--grow-m', type=float, default=0.03, help='box grown by this on every side')
    ap.add_argument('--shift-s', type=float, default=86400.0, help='seconds added to every stamp')
    ap.add_argument('--offset-ms', type=float, default=0.0,
                    help='added to image stamps to read the ground truth (clock offset)')
    here = os.path.dirname(os.path.abspath(__file__))
    ap.add_argument('--camera', default=os.path.join(here, '..', 'config', 'camera_tum_fr1.yaml'))
    ap.add_argument('--examples', type=int, default=4, help='before/after PNG pairs to save')
    ap.add_argument('--examples-dir', help='where (default OUT_DIR/../mask-examples)')
    a = ap.parse_args()

    src = os.path.abspath(a.tum_dir)
    out = os.path.abspath(a.out_dir)
    if os.path.realpath(src) == os.path.realpath(out):
        sys.exit('mask-object: OUT_DIR must differ from TUM_DIR')
    gt_path = a.gt or os.path.join(src, 'objects_gt.json')
    with open(gt_path) as f:
        gt = json.load(f)
    if a.pick:
        obj = pick_object(gt, a.eval)
    else:
        found = [o for o in gt['objects'] if o['id'] == a.object]
        if not found:
            sys.exit(f'mask-object: no object {a.object!r} in {gt_path}')
        obj = found[0]
    c = np.array(obj['centroid_m'], dtype=np.float64)
    half = np.array(obj['extent_m'], dtype=np.float64) / 2 + a.grow_m
    lo, hi = c - half, c + half
    if obj.get('on'):
        # A thing resting on another: its box reaches down to the support's top; growing it
        # downwards would take the support's surface around it.
        lo[2] = c[2] - obj['extent_m'][2] / 2 + 0.01
    # The other objects' own boxes (the support excepted): their points are never masked, where
    # the target's grown box overlaps them (a cup in front of a screen's foot stays).
    others = []
    for o in gt['objects']:
        if o is obj or o['id'] == obj.get('on'):
            continue
        oc = np.array(o['centroid_m'], dtype=np.float64)
        oh = np.array(o['extent_m'], dtype=np.float64) / 2
        if np.all(oc - oh <= hi) and np.all(oc + oh >= lo):
            others.append((oc - oh, oc + oh))

    k, dist, w, h, scale, cam_path = read_camera(src, a.camera)
    # Undistorted rays of every pixel (z = 1): p_cam = ray * depth.
    uv = np.stack(np.meshgrid(np.arange(w, dtype=np.float64), np.arange(h, dtype=np.float64)), -1)
    rays = cv2.undistortPoints(uv.reshape(-1, 1, 2), k, dist).reshape(h, w, 2)
    corners = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1])
                        for z in (lo[2], hi[2])])

    rgb_rows = read_list(os.path.join(src, 'rgb.txt'))
    depth_rows = read_list(os.path.join(src, 'depth.txt'))
    gt_rows = read_list(os.path.join(src, 'groundtruth.txt'))
    pose_at = pose_index(gt_rows, a.offset_ms / 1000.0)

    if os.path.exists(out):
        shutil.rmtree(out)
    os.makedirs(os.path.join(out, 'rgb'))
    os.makedirs(os.path.join(out, 'depth'))
    ex_dir = a.examples_dir or os.path.join(os.path.dirname(out), 'mask-examples')
    os.makedirs(ex_dir, exist_ok=True)

    ring_k = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (9, 9))
    grow_k = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (7, 7))
    hole_k = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (11, 11))

    def mask_for(depth, stamp):
        (t_wc, r_wc), _ = pose_at(stamp)
        z = depth.astype(np.float64) / scale
        valid = depth > 0
        # Camera points to world: p_w = R p_c + t.
        pc = np.concatenate([rays * z[..., None], z[..., None]], -1)
        pw = pc @ r_wc.T + t_wc
        inside = valid & np.all((pw >= lo) & (pw <= hi), axis=-1)
        keep = np.zeros((h, w), bool)  # points of other objects
        for olo, ohi in others:
            keep |= valid & np.all((pw >= olo) & (pw <= ohi), axis=-1)
        inside &= ~keep
        # Silhouette of the grown box (corners in front of the camera only).
        r_cw = r_wc.T
        pc_corners = (corners - t_wc) @ r_cw.T
        sil = np.zeros((h, w), np.uint8)
        if np.all(pc_corners[:, 2] > 0.05):
            rvec, _ = cv2.Rodrigues(r_cw)
            px, _ = cv2.projectPoints(corners, rvec, -r_cw @ t_wc, k, dist)
            px = px.reshape(-1, 2)
            if np.all(np.isfinite(px)) and np.all(np.abs(px) < 1e5):
                hull = cv2.convexHull(px.astype(np.float32)).astype(np.int32)
                cv2.fillConvexPoly(sil, hull, 1)
        m = inside.astype(np.uint8)
        if m.any():
            # Pixels without depth inside the silhouette, connected to the object's pixels: its
            # own depth holes (a black screen, a shiny surface).
            holes = ((sil > 0) & ~valid).astype(np.uint8)
            n, lab = cv2.connectedComponents(holes, connectivity=8)
            near = (cv2.dilate(m, hole_k) > 0) & (holes > 0)
            touched = np.unique(lab[near])
            touched = touched[touched > 0]
            m = (m > 0) | np.isin(lab, touched)
            m = (cv2.dilate(m.astype(np.uint8), grow_k) > 0) & ~keep
        return m > 0, int(inside.sum())

    def fill_depth(depth, m, stamp):
        """Masked pixels take the nearest of the background depths around the mask (left, right,
        above, below on the border ring) that lies behind the object's grown box along the pixel's
        ray; none behind it: no depth (not seen, rather than a made-up surface)."""
        (t_wc, r_wc), _ = pose_at(stamp)
        d = depth.copy()
        ring = (cv2.dilate(m.astype(np.uint8), ring_k) > 0) & ~m & (depth > 0)
        ys, xs = np.nonzero(m)
        y0, y1 = max(ys.min() - 6, 0), min(ys.max() + 7, h)
        x0, x1 = max(xs.min() - 6, 0), min(xs.max() + 7, w)
        v = np.where(ring[y0:y1, x0:x1], depth[y0:y1, x0:x1], 0).astype(np.int64)
        cands = []
        for flip_axis, axis in ((None, 1), (1, 1), (None, 0), (0, 0)):
            vv = v if flip_axis is None else np.flip(v, flip_axis)
            n = vv.shape[axis]
            idx = np.where(vv > 0, np.arange(n).reshape((1, -1) if axis == 1 else (-1, 1)), -1)
            idx = np.maximum.accumulate(idx, axis=axis)
            got = np.take_along_axis(vv, np.maximum(idx, 0), axis=axis)
            got = np.where(idx >= 0, got, 0)
            if flip_axis is not None:
                got = np.flip(got, flip_axis)
            cands.append(got)
        cands = np.stack(cands)  # 4 x crop, 0 = none
        # Depth (camera z) where each pixel's ray leaves the grown box: slab method, z = 1 rays.
        ray = np.concatenate([rays[y0:y1, x0:x1], np.ones((y1 - y0, x1 - x0, 1))], -1) @ r_wc.T
        with np.errstate(divide='ignore', invalid='ignore'):
            ta = (lo - t_wc) / ray
            tb = (hi - t_wc) / ray
        t_exit = np.min(np.where(np.isnan(np.maximum(ta, tb)), np.inf, np.maximum(ta, tb)), axis=-1)
        exit_units = np.where(np.isfinite(t_exit), t_exit * scale, 0)
        behind = np.where(cands > exit_units[None], cands, np.iinfo(np.int64).max)
        best = behind.min(axis=0)
        best = np.where(best == np.iinfo(np.int64).max, 0, best)
        sub = d[y0:y1, x0:x1]
        mm = m[y0:y1, x0:x1]
        sub[mm] = np.clip(best[mm], 0, 65535).astype(np.uint16)
        return d

    # Depth frames: mask and fill; remember each frame's mask for the RGB frames.
    masks = {}
    stats = {'depth_masked': 0, 'rgb_masked': 0, 'pixels': 0, 'max_gap_s': 0.0}
    depth_stamps = np.array([float(r[0]) for r in depth_rows])
    for r in depth_rows:
        stamp, name = float(r[0]), r[1]
        _, gap = pose_at(stamp)
        stats['max_gap_s'] = max(stats['max_gap_s'], gap)
        depth = cv2.imread(os.path.join(src, name), cv2.IMREAD_UNCHANGED)
        m, _ = mask_for(depth, stamp)
        dst = os.path.join(out, name)
        if m.any():
            masks[name] = m
            cv2.imwrite(dst, fill_depth(depth, m, stamp))
            stats['depth_masked'] += 1
            stats['pixels'] += int(m.sum())
        else:
            os.symlink(os.path.join(src, name), dst)

    # RGB frames: the mask of the nearest depth frame.
    examples = []
    for r in rgb_rows:
        stamp, name = float(r[0]), r[1]
        j = int(np.argmin(np.abs(depth_stamps - stamp)))
        m = masks.get(depth_rows[j][1])
        dst = os.path.join(out, name)
        if m is None:
            os.symlink(os.path.join(src, name), dst)
            continue
        img = cv2.imread(os.path.join(src, name), cv2.IMREAD_COLOR)
        filled = cv2.inpaint(img, m.astype(np.uint8) * 255, 5, cv2.INPAINT_TELEA)
        params = [cv2.IMWRITE_JPEG_QUALITY, 95] if name.lower().endswith(('.jpg', '.jpeg')) else []
        cv2.imwrite(dst, filled, params)
        stats['rgb_masked'] += 1
        examples.append((int(m.sum()), name, depth_rows[j][1]))

    # Before/after pairs: frames spread over the sequence among those with the most masked pixels.
    if examples and a.examples > 0:
        examples_sorted = sorted(examples, key=lambda e: -e[0])[:max(a.examples * 8, 1)]
        examples_sorted.sort(key=lambda e: e[1])
        step = max(len(examples_sorted) // a.examples, 1)
        for _, rname, dname in examples_sorted[::step][:a.examples]:
            before = cv2.imread(os.path.join(src, rname), cv2.IMREAD_COLOR)
            after = cv2.imread(os.path.join(out, rname), cv2.IMREAD_COLOR)
            db = cv2.imread(os.path.join(src, dname), cv2.IMREAD_UNCHANGED)
            da = cv2.imread(os.path.join(out, dname), cv2.IMREAD_UNCHANGED)
            vis = lambda d: cv2.applyColorMap(np.clip(d / scale / 4.0 * 255, 0, 255).astype(np.uint8),
                                              cv2.COLORMAP_JET)
            top = np.hstack([before, after])
            bottom = np.hstack([vis(db), vis(da)])
            base = os.path.splitext(os.path.basename(rname))[0]
            cv2.imwrite(os.path.join(ex_dir, f'{base}.png'), np.vstack([top, bottom]))

    # Stamped text files: shifted by --shift-s (file names unchanged); the rest symlinked.
    def shifted(name, rows_have_stamp=True):
        with open(os.path.join(src, name)) as f, open(os.path.join(out, name), 'w') as g:
            for line in f:
                s = line.strip()
                if s and not s.startswith('#') and rows_have_stamp:
                    parts = line.split()
                    t = float(parts[0]) + a.shift_s
                    decimals = len(parts[0].split('.')[1]) if '.' in parts[0] else 0
                    parts[0] = f'{t:.{decimals}f}'
                    line = ' '.join(parts) + '\n'
                g.write(line)
    stamped = {'rgb.txt', 'depth.txt', 'groundtruth.txt', 'accelerometer.txt'}
    for entry in sorted(os.listdir(src)):
        if entry in ('rgb', 'depth'):
            continue
        if entry in stamped:
            shifted(entry)
        else:
            os.symlink(os.path.join(src, entry), os.path.join(out, entry))

    print(f"mask-object: camera {cam_path}; box {np.round(lo, 3).tolist()}..{np.round(hi, 3).tolist()}"
          f" (grown {a.grow_m} m); masked {stats['depth_masked']}/{len(depth_rows)} depth and "
          f"{stats['rgb_masked']}/{len(rgb_rows)} rgb frames, {stats['pixels'] / max(stats['depth_masked'], 1):.0f}"
          f" px per masked frame; largest pose stamp gap {stats['max_gap_s'] * 1000:.1f} ms;"
          f" stamps shifted {a.shift_s:g} s; examples in {ex_dir}", file=sys.stderr)
    print(f"object: {obj['id']} {obj['class_name']}")


if __name__ == '__main__':
    main()
