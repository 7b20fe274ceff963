#!/usr/bin/env bash
# The main job on the built-in synthetic scene: no network, no data needed.
set -euo pipefail
set -x
mkdir -p out
csw synth out/synthetic --size 450x375 --dmax 64
csw bench --dataset synthetic --repeat 3
# The range comes from the calib.txt beside left.png (its ndisp), and the same calibration
# turns the map into depth (mm) and a coloured point cloud.
csw match out/synthetic/left.png out/synthetic/right.png -o out/synthetic-disp.pfm \
    --preview out/synthetic-preview.png --depth out/synthetic-depth.pfm \
    --depth-preview out/synthetic-depth.png --cloud out/synthetic-cloud.ply
csw match out/synthetic/left.png out/synthetic/right.png -o out/synthetic-disp-csw.pfm \
    --dmax 64 --csw --csw-rule unique --preview out/synthetic-preview-csw.png
csw score out/synthetic-disp-csw.pfm --gt out/synthetic/gt.pfm --mask nonocc=out/synthetic/nonocc.png
