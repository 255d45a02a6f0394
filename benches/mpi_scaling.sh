#!/usr/bin/env bash
# Throughput of `bezchain optimise` and `bezchain eval` on 1 MPI rank against N ranks (default
# 2), one thread a rank (RAYON_NUM_THREADS=1), on the CPU evaluator: the README's MPI table.
#
#   benches/mpi_scaling.sh [OBJECTIVE] [RANKS] [REPEATS]
#
# OBJECTIVE is `optimise --objective`'s (default max-cl; inverse:TARGET, or a viscous
# objective once there is one). Every run of a pair does the same work (the same seed gives the
# same bits on any number of ranks), so the throughput ratio is the ratio of wall times; each
# time is the median of REPEATS (default 3) runs. The load average before and after is printed:
# other jobs on the cores skew the ratio. Needs OpenMPI (mpirun) and builds
# `cargo build --release --features mpi` first.
set -euo pipefail
cd "$(dirname "$0")/.."
root=$PWD
objective=${1:-max-cl}
label=$objective
ranks=${2:-2}
repeats=${3:-3}
cargo build --release --features mpi --quiet
bin=$PWD/target/release/bezchain
if [ "$(id -u)" -eq 0 ]; then export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1; fi
export RAYON_NUM_THREADS=1
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
cd "$work"
"$bin" naca 0012 -o n0012.dat >/dev/null
"$bin" naca 4412 -o n4412.dat >/dev/null
objective=${objective//n4412.dat/$work/n4412.dat}

# The median wall time of REPEATS runs of `mpirun -n $1 bezchain ${@:2}`.
median() {
  local n=$1; shift
  for _ in $(seq "$repeats"); do
    local t0 t1
    t0=$(date +%s.%N)
    mpirun --oversubscribe --bind-to none -n "$n" "$bin" "$@" >/dev/null 2>"$work/err" || { cat "$work/err" >&2; exit 1; }
    t1=$(date +%s.%N)
    awk -v a="$t0" -v b="$t1" 'BEGIN { print b - a }'
  done | sort -g | awk '{ a[NR] = $1 } END { printf "%.3f", a[int((NR + 1) / 2)] }'
}

echo "load average before: $(cut -d' ' -f1-3 /proc/loadavg) on $(nproc) cores"
printf '%-58s %10s %10s %8s\n' "run" "1 rank, s" "$ranks ranks, s" "speed-up"
row() {
  local name=$1; shift
  local t1 tn
  t1=$(median 1 "$@")
  tn=$(median "$ranks" "$@")
  printf '%-58s %10s %10s %7.2fx\n' "$name" "$t1" "$tn" "$(awk -v a="$t1" -v b="$tn" 'BEGIN { print a / b }')"
}
row "optimise --objective $label --method ga (P 1024, 30 gen.)" \
  optimise n0012.dat --objective "$objective" --method ga --population 1024 --generations 30 --backend cpu --json o.json
row "optimise --objective $label --method cmaes (λ 128, 100 gen.)" \
  optimise n0012.dat --objective "$objective" --method cmaes --population 128 --generations 100 --backend cpu --json o.json
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
row "eval (20,000 chains of the paper's case 1, 8 Newton steps)" \
  eval fit.json --population pop.csv --points "$data" --backend cpu -o fit.csv
echo "load average after: $(cut -d' ' -f1-3 /proc/loadavg)"
