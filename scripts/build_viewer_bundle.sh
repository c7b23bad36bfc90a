#!/bin/sh
# Rebuild foldprint/data/viewer/three-viewer.min.js: the parts of three.js the fold viewer
# uses (scripts/viewer_bundle_entry.js), bundled by esbuild into one classic script that
# sets window.FOLDPRINT_THREE. A classic script, because browsers refuse ES modules from
# file:// pages, and the gallery must open from disk with no network.
set -eu
THREE=0.187.0
ESBUILD=0.28.2
here=$(cd "$(dirname "$0")/.." && pwd)
work=$(mktemp -d)
cp "$here/scripts/viewer_bundle_entry.js" "$work/entry.js"
cd "$work"
npm init -y >/dev/null
npm install --no-audit --no-fund "three@$THREE" "esbuild@$ESBUILD" >/dev/null
node_modules/.bin/esbuild entry.js --bundle --minify --format=iife --global-name=FOLDPRINT_THREE \
  --legal-comments=inline --target=es2020 --outfile="$here/foldprint/data/viewer/three-viewer.min.js"
cp node_modules/three/LICENSE "$here/foldprint/data/viewer/LICENSE-three.txt"
rm -rf "$work"
