#!/usr/bin/env bash
# Cuts the small real sample shipped in tests/data from a full TUM sequence (how it was made).
# usage: scripts/make-sample.sh SRC_DIR DST_DIR FIRST_STAMP COUNT
set -euo pipefail
src=$1 dst=$2 first=$3 count=$4
mkdir -p "$dst/rgb" "$dst/depth"
python3 - "$src" "$dst" "$first" "$count" <<'PY'
import sys, shutil, os
src, dst, first, count = sys.argv[1], sys.argv[2], float(sys.argv[3]), int(sys.argv[4])
def rows(name):
    return [l.split() for l in open(os.path.join(src, name)) if l.strip() and not l.startswith('#')]
rgb = [r for r in rows('rgb.txt') if float(r[0]) >= first][:count]
t0, t1 = float(rgb[0][0]) - 0.1, float(rgb[-1][0]) + 0.1
depth = [r for r in rows('depth.txt') if t0 <= float(r[0]) <= t1]
for name, sel in (('rgb.txt', rgb), ('depth.txt', depth)):
    with open(os.path.join(dst, name), 'w') as f:
        f.write('# cut from %s by scripts/make-sample.sh\n# timestamp filename\n' % os.path.basename(src.rstrip('/')))
        for r in sel:
            f.write(' '.join(r) + '\n')
            shutil.copy(os.path.join(src, r[1]), os.path.join(dst, r[1]))
for name in ('groundtruth.txt', 'accelerometer.txt'):
    p = os.path.join(src, name)
    if os.path.exists(p):
        with open(os.path.join(dst, name), 'w') as f:
            for l in open(p):
                if l.startswith('#') or t0 - 0.5 <= float(l.split()[0]) <= t1 + 0.5:
                    f.write(l)
PY
echo "sample: $(wc -l < "$dst/rgb.txt") lines in $dst/rgb.txt"
