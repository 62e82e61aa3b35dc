#!/usr/bin/env python3
"""Orientation residuals of TUM trajectories against a ground truth (no numpy needed).

usage: scripts/orientation-residuals.py GROUNDTRUTH OFFSET_MS TRAJ [TRAJ ...]

The trajectories (TUM format, e.g. `loci export --trajectories DIR` or `loci bench track
--trajectory`) are taken as one set of camera orientations in one frame. Prints, for the ground
truth read OFFSET_MS after each stamp (fr1_rpy: -7, the images' clock offset):
  - the residual per pose after the one rotation that best aligns the set to the ground truth
    (chordal mean), median and RMS, also by the ground truth's angular speed;
  - the same with a constant camera-frame rotation fitted as well (the estimate's camera frame
    against the ground truth's, a hand-eye offset), and that rotation.
The residual is the floor that any single pair of poses (such as the two-robot test's B-from-A) is
measured against.
"""
import math
import sys


def q2m(q):
    x, y, z, w = q
    n = math.sqrt(x * x + y * y + z * z + w * w)
    x, y, z, w = x / n, y / n, z / n, w / n
    return [[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]]


def mul(a, b):
    return [[sum(a[i][k] * b[k][j] for k in range(3)) for j in range(3)] for i in range(3)]


def tr(a):
    return [[a[j][i] for j in range(3)] for i in range(3)]


def angle_deg(m):
    c = max(-1.0, min(1.0, (m[0][0] + m[1][1] + m[2][2] - 1) / 2))
    return math.degrees(math.acos(c))


def log_deg(m):
    a = math.radians(angle_deg(m))
    if a < 1e-9:
        return [0.0, 0.0, 0.0]
    s = 2 * math.sin(a)
    v = [(m[2][1] - m[1][2]) / s, (m[0][2] - m[2][0]) / s, (m[1][0] - m[0][1]) / s]
    return [math.degrees(a) * x for x in v]


def best_rotation(pairs):
    """The rotation R maximising tr(R^T M), M the sum of `pairs`: Horn's quaternion method
    (which maximises tr(R S) for S = M^T)."""
    s = [[sum(p[j][i] for p in pairs) for j in range(3)] for i in range(3)]
    sxx, sxy, sxz = s[0]
    syx, syy, syz = s[1]
    szx, szy, szz = s[2]
    n = [[sxx + syy + szz, syz - szy, szx - sxz, sxy - syx],
         [syz - szy, sxx - syy - szz, sxy + syx, szx + sxz],
         [szx - sxz, sxy + syx, -sxx + syy - szz, syz + szy],
         [sxy - syx, szx + sxz, syz + szy, -sxx - syy + szz]]
    shift = sum(abs(v) for row in n for v in row)
    q = [1.0, 0.0, 0.0, 0.0]
    for _ in range(500):  # power iteration on N + shift * I (largest eigenvalue)
        q2 = [sum(n[i][j] * q[j] for j in range(4)) + shift * q[i] for i in range(4)]
        norm = math.sqrt(sum(v * v for v in q2))
        q = [v / norm for v in q2]
    w, x, y, z = q
    return q2m([x, y, z, w])


def load(path):
    rows = []
    for line in open(path):
        f = line.split()
        if line.startswith("#") or len(f) != 8:
            continue
        rows.append((float(f[0]), [float(v) for v in f[4:8]]))
    return rows


def gt_at(gt, t):
    lo, hi = 0, len(gt) - 1
    while hi - lo > 1:
        mid = (lo + hi) // 2
        if gt[mid][0] <= t:
            lo = mid
        else:
            hi = mid
    (t0, q0), (t1, q1) = gt[lo], gt[hi]
    a = min(1.0, max(0.0, (t - t0) / (t1 - t0))) if t1 > t0 else 0.0
    if sum(x * y for x, y in zip(q0, q1)) < 0:
        q1 = [-v for v in q1]
    return q2m([(1 - a) * x + a * y for x, y in zip(q0, q1)])


def summary(label, res):
    s = sorted(res)
    rms = math.sqrt(sum(r * r for r in res) / len(res))
    print(f"{label}: {len(res)} poses, residual median {s[len(s) // 2]:.3f} deg, rms {rms:.3f} deg")


def main():
    if len(sys.argv) < 4:
        print(__doc__, file=sys.stderr)
        return 2
    gt = load(sys.argv[1])
    off_s = float(sys.argv[2]) * 1e-3
    est, truth, speed = [], [], []
    for path in sys.argv[3:]:
        for t, q in load(path):
            est.append(q2m(q))
            truth.append(gt_at(gt, t + off_s))
            speed.append(angle_deg(mul(tr(gt_at(gt, t + off_s - 0.01)), gt_at(gt, t + off_s + 0.01))) / 0.02)
    # E_i ~ W G_i: W is the chordal mean of E_i G_i^T.
    w = best_rotation([mul(e, tr(g)) for e, g in zip(est, truth)])
    res = [angle_deg(mul(tr(mul(w, g)), e)) for e, g in zip(est, truth)]
    summary("one rotation", res)
    for lo, hi in [(0, 30), (30, 60), (60, 90), (90, 1000)]:
        sel = [r for r, s in zip(res, speed) if lo <= s < hi]
        if sel:
            summary(f"  ground truth turning {lo}-{hi} deg/s", sel)
    # E_i ~ W G_i D, alternating: D the chordal mean of G_i^T W^T E_i, then W of E_i D^T G_i^T.
    d = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]
    for _ in range(20):
        d = best_rotation([mul(tr(mul(w, g)), e) for e, g in zip(est, truth)])
        w = best_rotation([mul(mul(e, tr(d)), tr(g)) for e, g in zip(est, truth)])
    res = [angle_deg(mul(tr(mul(mul(w, g), d)), e)) for e, g in zip(est, truth)]
    summary("plus a camera-frame rotation", res)
    v = log_deg(d)
    print(f"  camera-frame rotation (x, y, z of the camera, deg): {v[0]:+.3f} {v[1]:+.3f} {v[2]:+.3f}"
          f" (|{math.sqrt(sum(x * x for x in v)):.3f}|)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
