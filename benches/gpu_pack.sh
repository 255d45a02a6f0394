#!/usr/bin/env bash
# Build what benches/gpu_device.sh runs on a GPU machine and pack it into one tarball: the
# release `bezchain` and the test executables that touch the GPU, stripped, each renamed
# `test-NAME` (`test-lib` for the library's own tests).
#
# Usage: benches/gpu_pack.sh OUT.tgz
# Then, on the GPU machine, in a copy of this checkout:
#   mkdir -p /tmp/dv && tar xzf OUT.tgz -C /tmp/dv && benches/gpu_device.sh /tmp/dv /tmp/logs
# (a machine without a Vulkan loader needs libvulkan1 unpacked first; NVIDIA's driver file is
# then named by VK_DRIVER_FILES).
set -euo pipefail
out=${1:?OUT.tgz}
cd "$(dirname "$0")/.."
tests=(aero_batch eval_batch eval_dense eval_fallback eval_parity evo_curve fuzz shaders)
args=()
for t in "${tests[@]}"; do args+=(--test "$t"); done
cargo build --release
json=$(mktemp)
dir=$(mktemp -d)
trap 'rm -rf "$json" "$dir"' EXIT
cargo test --release --no-run --lib "${args[@]}" --message-format=json >"$json"
python3 - "$json" "$dir" <<'EOF'
import json, shutil, sys
out = sys.argv[2]
for line in open(sys.argv[1]):
    msg = json.loads(line)
    exe = msg.get("executable")
    if msg.get("reason") != "compiler-artifact" or not exe or not msg.get("profile", {}).get("test"):
        continue
    kinds = msg["target"]["kind"]
    name = "lib" if "lib" in kinds else msg["target"]["name"]
    shutil.copy(exe, f"{out}/test-{name}")
EOF
cp target/release/bezchain "$dir/"
strip "$dir"/* 2>/dev/null || true
tar czf "$out" -C "$dir" .
echo "$out: $(ls "$dir" | tr '\n' ' ')($(du -h "$out" | cut -f1))"
