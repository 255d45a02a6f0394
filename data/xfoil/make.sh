#!/bin/sh
# Regenerate data/xfoil/inviscid.csv: XFOIL's inviscid CL and CM at 0°, 4° and 8° for every
# aerofoil file the project ships, XFOIL's default paneling (PANE: 160 nodes).
#
#   apt-get install -y xfoil xvfb xauth xfonts-base   (XFOIL dies on X_OpenFont without the fonts)
#   sh data/xfoil/make.sh > data/xfoil/inviscid.csv     (from the repository root)
#
# XFOIL opens a display even when it draws nothing, so it runs under xvfb-run. Each file is
# loaded, paneled with PANE and analysed at the three angles; pol.txt is read back.
set -eu
root=$(pwd)
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
echo "# XFOIL $(printf 'QUIT\n' | xvfb-run -a xfoil 2>/dev/null | sed -n 's/.*XFOIL Version \([0-9.]*\).*/\1/p' | head -1) inviscid, PANE (160 nodes), per file:"
echo "# printf 'LOAD a.dat\\\\n\\\\nPANE\\\\nOPER\\\\nPACC\\\\npol.txt\\\\n\\\\nALFA 0\\\\nALFA 4\\\\nALFA 8\\\\n\\\\nQUIT\\\\n' | xvfb-run -a xfoil"
echo "file,alpha,cl,cm"
for f in data/naca4413.dat data/airfoils/*.dat; do
    cp "$root/$f" "$work/a.dat"
    rm -f "$work/pol.txt"
    (cd "$work" && printf 'LOAD a.dat\n\nPANE\nOPER\nPACC\npol.txt\n\nALFA 0\nALFA 4\nALFA 8\n\nQUIT\n' \
        | xvfb-run -a xfoil > out.txt 2>&1) || true
    if [ ! -s "$work/pol.txt" ] || ! grep -q '^ *8\.000' "$work/pol.txt"; then
        echo "# $f: XFOIL failed ($(grep -m1 -i 'error' "$work/out.txt" || echo 'no polar'))"
        continue
    fi
    awk -v f="$f" '/^ *-?[0-9]+\.[0-9]+ +-?[0-9]/ { print f "," $1 "," $2 "," $5 }' "$work/pol.txt"
done
