#!/bin/sh
# Regenerate data/xfoil/viscous.csv: XFOIL's viscous polar at Re 1e6, Ncrit 9 (XFOIL's default),
# Mach 0, α from -2° to 8° by continuation, XFOIL's default paneling (PANE: 160 nodes), for every
# aerofoil file the project ships. Points XFOIL does not converge are absent from its polar.
#
#   apt-get install -y xfoil xvfb xauth xfonts-base   (XFOIL dies on X_OpenFont without the fonts)
#   sh data/xfoil/make_viscous.sh > data/xfoil/viscous.csv     (from the repository root)
set -eu
root=$(pwd)
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
cmds='LOAD a.dat\n\nPANE\nOPER\nVISC 1e6\nITER 200\nPACC\npol.txt\n\nASEQ -2 8 1\n\nQUIT\n'
echo "# XFOIL $(printf 'QUIT\n' | xvfb-run -a xfoil 2>/dev/null | sed -n 's/.*XFOIL Version \([0-9.]*\).*/\1/p' | head -1) viscous, Re 1e6, Ncrit 9, PANE (160 nodes), per file:"
echo "# printf '$(printf '%s' "$cmds" | sed 's/\\/\\\\/g')' | xvfb-run -a xfoil"
echo "file,alpha,cl,cd,cdp,cm,xtr_top,xtr_bottom"
for f in data/naca4413.dat data/airfoils/*.dat; do
    cp "$root/$f" "$work/a.dat"
    rm -f "$work/pol.txt"
    (cd "$work" && printf "$cmds" | xvfb-run -a xfoil > out.txt 2>&1) || true
    if [ ! -s "$work/pol.txt" ] || ! grep -q '^ *-\?[0-9]\+\.[0-9]\+ \+-\?[0-9]' "$work/pol.txt"; then
        echo "# $f: XFOIL failed ($(grep -m1 -i 'error' "$work/out.txt" || echo 'no polar'))"
        continue
    fi
    awk -v f="$f" '/^ *-?[0-9]+\.[0-9]+ +-?[0-9]/ { print f "," $1 "," $2 "," $3 "," $4 "," $5 "," $6 "," $7 }' "$work/pol.txt"
done
