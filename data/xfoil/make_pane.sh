#!/bin/sh
# Regenerate data/xfoil/pane/*.dat: the panel nodes XFOIL's PANE (160 nodes, default
# parameters) places on three aerofoil files of different families, written by PSAV.
#
#   apt-get install -y xfoil xvfb xauth xfonts-base
#   sh data/xfoil/make_pane.sh          (from the repository root)
set -eu
root=$(pwd)
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
mkdir -p "$root/data/xfoil/pane"
for f in data/airfoils/naca4412.dat data/airfoils/regressions/naca63209.dat data/airfoils/regressions/fx77w270.dat; do
    cp "$root/$f" "$work/a.dat"
    rm -f "$work/b.dat"
    (cd "$work" && printf 'LOAD a.dat\n\nPANE\nPSAV b.dat\n\nQUIT\n' | xvfb-run -a xfoil > out.txt 2>&1) || true
    [ -s "$work/b.dat" ] || { echo "$f: XFOIL wrote no nodes" >&2; exit 1; }
    cp "$work/b.dat" "$root/data/xfoil/pane/$(basename "$f")"
done
