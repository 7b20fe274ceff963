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
# CSW's B-map skip is local matching's (the default, semi-global matching, needs every
# cost): the accurate preset with the unique rule.
csw match out/synthetic/left.png out/synthetic/right.png -o out/synthetic-disp-csw.pfm \
    --dmax 64 --preset accurate --csw --csw-rule unique --preview out/synthetic-preview-csw.png
for map in out/synthetic-disp.pfm out/synthetic-disp-csw.pfm; do
    csw score "$map" --gt out/synthetic/gt.pfm --mask nonocc=out/synthetic/nonocc.png
done
set +x
echo "Results are in out/: the disparity maps (synthetic-disp*.pfm), depth (synthetic-depth.pfm) and the point cloud (synthetic-cloud.ply)." >&2
echo "Open out/synthetic-preview.png to see the disparity map, out/synthetic-depth.png for depth." >&2
