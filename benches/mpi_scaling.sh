#!/usr/bin/env bash
# Throughput of `bezchain optimise` and `bezchain eval` on 1 MPI rank against N ranks (default
# 2), one thread a rank (RAYON_NUM_THREADS=1), on the CPU evaluator: the rows of the MPI table
# of docs/GUIDE.md, printed as its Markdown rows.
#
#   benches/mpi_scaling.sh [OBJECTIVE] [RANKS] [REPEATS]
#
# OBJECTIVE is `optimise --objective`'s (default max-cl; inverse:TARGET; the viscous max-ld and
# min-cd, scored at --re $RE, default 1e6, and --alpha 4, with populations sized for the
# viscous analysis's few shapes a second). Every run of a pair does the same work (the same
# seed gives the same bits on any number of ranks), so the throughput ratio is the ratio of
# wall times; each time is the median of REPEATS (default 3) runs, the 1-rank and N-rank runs
# alternating. The load average before and after is printed: other jobs on the cores skew the
# ratio (with more processes than cores, N ranks also get a larger share of the machine). Needs
# OpenMPI (mpirun) and builds `cargo build --release --features mpi` first, unless
# BEZCHAIN_BIN names a binary built with `--features mpi` to measure instead.
set -euo pipefail
cd "$(dirname "$0")/.."
root=$PWD
objective=${1:-max-cl}
label=$objective
ranks=${2:-2}
repeats=${3:-3}
if [ -z "${BEZCHAIN_BIN:-}" ]; then
  cargo build --release --features mpi --quiet
fi
bin=$(realpath "${BEZCHAIN_BIN:-target/release/bezchain}")
if [ "$(id -u)" -eq 0 ]; then export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1; fi
export RAYON_NUM_THREADS=1
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
cd "$work"
"$bin" naca 0012 -o n0012.dat >/dev/null
"$bin" naca 4412 -o n4412.dat >/dev/null
objective=${objective//n4412.dat/$work/n4412.dat}

# The wall time of `mpirun -n $1 bezchain ${@:2}`, seconds.
timed() {
  local n=$1; shift
  local t0 t1
  t0=$(date +%s.%N)
  mpirun --oversubscribe --bind-to none -n "$n" "$bin" "$@" >/dev/null 2>"$work/err" || { cat "$work/err" >&2; exit 1; }
  t1=$(date +%s.%N)
  awk -v a="$t0" -v b="$t1" 'BEGIN { print b - a }'
}

# The median of the numbers on standard input.
median() {
  sort -g | awk '{ a[NR] = $1 } END { printf "%.3f", a[int((NR + 1) / 2)] }'
}

echo "load average before: $(cut -d' ' -f1-3 /proc/loadavg) on $(nproc) cores"
echo "| run (seconds) | 1 rank | $ranks ranks | speed-up |"
echo "|---|---|---|---|"
# One table row: REPEATS pairs of runs on 1 and on N ranks, one after the other (so a change in
# the load falls on both alike), and their medians.
row() {
  local name=$1; shift
  local one=() many=() t1 tn
  for _ in $(seq "$repeats"); do
    one+=("$(timed 1 "$@")")
    many+=("$(timed "$ranks" "$@")")
  done
  t1=$(printf '%s\n' "${one[@]}" | median)
  tn=$(printf '%s\n' "${many[@]}" | median)
  printf '| %s | %s | %s | %.2f× |\n' "$name" "$t1" "$tn" "$(awk -v a="$t1" -v b="$tn" 'BEGIN { print a / b }')"
}
case $objective in
  max-ld | min-cd)
    # The viscous analysis: a shape's viscous-inviscid Newton solve costs milliseconds, so a
    # generation of 64 is seconds.
    re=${RE:-1e6}
    if [ "$objective" = min-cd ]; then
      viscous=(--re "$re" --cl 0.5) # at a design CL
    else
      viscous=(--re "$re" --alpha 4)
    fi
    row "\`optimise --objective $label --re $re --method ga\` (P 64, 6 gen.)" \
      optimise n0012.dat --objective "$objective" "${viscous[@]}" --method ga --population 64 --generations 6 --backend cpu --json o.json
    row "\`optimise --objective $label --re $re --method cmaes\` (λ 32, 8 gen.)" \
      optimise n0012.dat --objective "$objective" "${viscous[@]}" --method cmaes --population 32 --generations 8 --backend cpu --json o.json
    ;;
  *)
    row "\`optimise --objective $label --method ga\` (P 1024, 30 gen.)" \
      optimise n0012.dat --objective "$objective" --method ga --population 1024 --generations 30 --backend cpu --json o.json
    row "\`optimise --objective $label --method cmaes\` (λ 128, 100 gen.)" \
      optimise n0012.dat --objective "$objective" --method cmaes --population 128 --generations 100 --backend cpu --json o.json
    ;;
esac
# eval: 20,000 individuals around a fit of the paper's data (degree 3 x 5 segments).
data=$root/data/naca4413.dat
"$bin" fit "$data" --degree 3 --segments 5 --json fit.json >/dev/null
python3 - <<'PY'
import json, random
d = [x for p in json.load(open("fit.json"))["design_points"] for x in p]
random.seed(1)
with open("pop.csv", "w") as f:
    for k in range(20000):
        f.write(",".join(repr(x + (1e-3 * random.gauss(0, 1) if k else 0.0)) for x in d) + "\n")
PY
row "\`eval\` (20,000 chains of the paper's case 1, 8 Newton steps)" \
  eval fit.json --population pop.csv --points "$data" --backend cpu -o fit.csv
echo "load average after: $(cut -d' ' -f1-3 /proc/loadavg)"
