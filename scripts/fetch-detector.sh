#!/usr/bin/env bash
# Brings the server-side detector of config/server-detector.yaml, YOLOX-S (COCO-80, ONNX,
# 640x640, Apache-2.0), into models/yolox_s/. The weights are not in the repository (36 MB).
#   scripts/fetch-detector.sh              download the official release asset
#   scripts/fetch-detector.sh FILE         use a yolox_s.onnx already on this machine
# Source: Megvii-BaseDetection/YOLOX, release 0.1.1rc0, asset yolox_s.onnx (the ONNX export of
# the official COCO weights, the same release YOLOX-Nano's conversion came from). Set
# LOCI_YOLOX_S_SHA256 to pin the file's checksum; the script prints the one it got and keeps it
# in models/yolox_s/SHA256.
set -euo pipefail

ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
DEST="$ROOT/models/yolox_s"
URL="https://github.com/Megvii-BaseDetection/YOLOX/releases/download/0.1.1rc0/yolox_s.onnx"
mkdir -p "$DEST"
tmp="$(mktemp "$DEST/.yolox_s.XXXXXX")"
trap 'rm -f "$tmp"' EXIT

if [ $# -ge 1 ]; then
  cp "$1" "$tmp"
else
  echo "downloading $URL" >&2
  if ! curl -fL --retry 2 -o "$tmp" "$URL"; then
    echo "error: could not download $URL (no network?); pass a local yolox_s.onnx instead" >&2
    exit 1
  fi
fi
sum="$(sha256sum "$tmp" | awk '{print $1}')"
if [ -n "${LOCI_YOLOX_S_SHA256:-}" ] && [ "$sum" != "$LOCI_YOLOX_S_SHA256" ]; then
  echo "error: sha256 $sum is not the pinned $LOCI_YOLOX_S_SHA256" >&2
  exit 1
fi
# An ONNX file is a protobuf ModelProto; a Git-LFS pointer or an HTML error page is text.
if head -c 200 "$tmp" | grep -qE "git-lfs|<html|<!DOCTYPE"; then
  echo "error: $([ $# -ge 1 ] && echo "$1" || echo "$URL") is not an ONNX model" >&2
  exit 1
fi
mv "$tmp" "$DEST/yolox_s.onnx"
trap - EXIT
echo "$sum  yolox_s.onnx" > "$DEST/SHA256"
cp "$ROOT/models/yolox_nano/LICENSE" "$DEST/LICENSE"  # the same upstream (YOLOX, Apache-2.0)
echo "models/yolox_s/yolox_s.onnx  sha256 $sum" >&2
