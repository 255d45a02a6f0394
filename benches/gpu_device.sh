#!/usr/bin/env bash
# The GPU checks and timings in one run, for a machine with a real GPU (the README's
# "On a GPU" figures come from it): the GPU tests with BEZCHAIN_REQUIRE_GPU=1, `bezchain bench`
# of the fitness and panel kernels on the GPU and the CPU, the viscous kernel on the CPU, and
# the JAX/numpy peer on the same GPU, and the viscous Newton step's dense algebra batched there.
#
# Usage: benches/gpu_device.sh BIN_DIR LOG_DIR
#   BIN_DIR holds `bezchain` (release) and the test executables as `test-NAME`
#   (benches/gpu_pack.sh builds and packs them); built elsewhere they still read this
#   checkout's data through the path they were built in, which the script links here.
# Every command's output goes to LOG_DIR, one line per run is printed. QUICK=1 runs small
# sizes and the tests' first file only, to try the script on lavapipe.
set -u
quick=${QUICK:-0}
bin=$(cd "${1:?BIN_DIR}" && pwd)
log=${2:?LOG_DIR}
mkdir -p "$log"
root=$(pwd)
export BEZCHAIN_REQUIRE_GPU=1

{ nvidia-smi --query-gpu=name,driver_version,memory.total,clocks.max.sm --format=csv 2>/dev/null || echo "no nvidia-smi"; } | tee "$log/gpu.txt"
nproc | sed 's/^/cpus: /' | tee -a "$log/gpu.txt"

# The test executables name the checkout they were built in, and the binary under it.
built=$(grep -aom1 '/[[:alnum:]/._+-]*/data/naca4413.dat' "$bin/test-eval_parity" | head -1)
built=${built%/data/naca4413.dat}
if [ -n "$built" ] && [ "$built" != "$root" ] && [ ! -e "$built" ]; then
    mkdir -p "$(dirname "$built")" && ln -s "$root" "$built"
fi
mkdir -p target/release && cp "$bin/bezchain" target/release/bezchain
bz=target/release/bezchain

echo "== GPU tests (BEZCHAIN_REQUIRE_GPU=1)"
status=0
tests=("$bin"/test-*)
[ "$quick" = 1 ] && tests=("$bin/test-shaders")
for t in "${tests[@]}"; do
    name=${t##*/test-}
    if timeout 300 "$t" --test-threads 8 >"$log/test-$name.txt" 2>&1; then
        echo "  $name: $(grep -E '^test result' "$log/test-$name.txt" | tail -1)"
    else
        status=1
        echo "  $name FAILED: $(grep -E '^test result' "$log/test-$name.txt" | tail -1)"
        grep -E -A12 '^---- ' "$log/test-$name.txt" | head -60
    fi
done

echo "== bezchain bench"
run_bench() { # label, then bench arguments
    local label=$1
    shift
    if timeout 150 "$bz" bench --no-peak-measure "$@" --json "$log/bench-$label.json" >"$log/bench-$label.txt" 2>&1; then
        python3 - "$log/bench-$label.json" "$label" <<'EOF'
import json, sys
r = json.load(open(sys.argv[1]))
keys = ["seconds_median", "seconds", "gflops", "evals_per_second", "shapes_per_second", "points_per_second", "converged", "points", "invalid"]
got = {k: r[k] for k in keys if k in r}
print(f"  {sys.argv[2]:28s} {json.dumps(got)}  [{r.get('adapter', r.get('backend', ''))}]")
EOF
    else
        status=1
        echo "  $label FAILED"
        tail -5 "$log/bench-$label.txt"
    fi
}
sizes=(1024 4096 65536) aero=(1024 16384) peers=(4096 65536) visc=256
[ "$quick" = 1 ] && sizes=(64) aero=(64) peers=(64) visc=4
for p in "${sizes[@]}"; do
    for k in 0 2; do
        run_bench "fitness-gpu-P$p-K$k" --backend gpu --population "$p" --points 4096 --newton "$k"
        run_bench "fitness-cpu-P$p-K$k" --backend cpu --population "$p" --points 4096 --newton "$k"
    done
done
# The host's share at the largest population: 64 points leave little but the population's
# preparation, upload and the read-back.
run_bench "fitness-gpu-P${sizes[-1]}-K0-N64" --backend gpu --population "${sizes[-1]}" --points 64
for p in "${aero[@]}"; do
    run_bench "aero-gpu-P$p" --kernel aero --backend gpu --population "$p"
    run_bench "aero-cpu-P$p" --kernel aero --backend cpu --population "$p"
done
run_bench "viscous-cpu-P$visc" --kernel viscous --population "$visc"

echo "== peers on the same GPU (benches/peers/population.py)"
for p in "${peers[@]}"; do
    PYTHONUNBUFFERED=1 timeout 200 python3 benches/peers/population.py --bezchain "$bz" --backend gpu \
        --population "$p" --points 4096 --rounds 5 --jax-chunk "$p" 2>&1 | tee "$log/peer-P$p.txt" | tail -6
done
echo "== the viscous Newton step's dense solve, batched on this GPU (benches/peers/batched_lu.py)"
PYTHONUNBUFFERED=1 timeout 120 python3 benches/peers/batched_lu.py --n 186 --batch 2816 2>&1 | tee "$log/batched-lu.txt"
exit $status
