#!/usr/bin/env bash
# The main job on the built-in synthetic scene: no network, no data needed.
set -euo pipefail
set -x
mkdir -p out
csw synth out/synthetic --size 450x375 --dmax 64
csw match out/synthetic/left.png out/synthetic/right.png -o out/synthetic-disp.pfm \
    --dmax 64 --preview out/synthetic-preview.png
csw match out/synthetic/left.png out/synthetic/right.png -o out/synthetic-disp-csw.pfm \
    --dmax 64 --csw --tau auto --preview out/synthetic-preview-csw.png
