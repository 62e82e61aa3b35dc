#!/usr/bin/env bash
# Downloads a TUM RGB-D sequence from the official site and unpacks it for loci.
# usage: scripts/fetch-tum.sh SEQUENCE [DEST_DIR]
#   SEQUENCE like freiburg1_rpy, freiburg1_xyz, freiburg2_desk, freiburg3_walking_xyz
#   DEST_DIR defaults to $LOCI_DATA or ./data; the sequence lands in DEST_DIR/tum_<short name>
#   (e.g. data/tum_fr1_rpy), the layout every loci tool takes with --tum DIR.
set -euo pipefail

seq="${1:-}"
if [ -z "$seq" ] || [[ "$seq" == -* ]]; then
  sed -n '2,6p' "$0" | sed 's/^# \{0,1\}//'
  exit 2
fi
dest="${2:-${LOCI_DATA:-./data}}"
seq="${seq#rgbd_dataset_}"
case "$seq" in
  freiburg[123]_*) ;;
  *) echo "error: '$seq' is not a TUM RGB-D sequence name (expected freiburgN_name)" >&2; exit 2 ;;
esac
fr="${seq%%_*}"                       # freiburg1
short="tum_fr${fr#freiburg}_${seq#*_}" # tum_fr1_rpy
url="https://cvg.cit.tum.de/rgbd/dataset/${fr}/rgbd_dataset_${seq}.tgz"

mkdir -p "$dest"
out="$dest/$short"
if [ -f "$out/rgb.txt" ]; then
  echo "already present: $out"
  exit 0
fi
tmp="$(mktemp -d)"
trap 'rm -rf "$tmp"' EXIT
echo "downloading $url"
if ! curl -fL --retry 2 --connect-timeout 15 -o "$tmp/seq.tgz" "$url"; then
  echo "error: could not download $url" >&2
  echo "       (no network? the TUM site is https://cvg.cit.tum.de/data/datasets/rgbd-dataset)" >&2
  exit 1
fi
tar -xzf "$tmp/seq.tgz" -C "$tmp"
mv "$tmp/rgbd_dataset_${seq}" "$out"
echo "ready: $out ($(grep -vc '^#' "$out/rgb.txt") frames); use: --tum $out"
