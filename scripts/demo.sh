#!/usr/bin/env bash
# `make demo`: the toolchain from module files to the paper's experiment, echoing every command as
# a user would type it.
#
# 1. The SDK's example modules (already built by `make modules`) packed as extended Intel HEX by
#    both routes (ELF relocations, and the paper's binary + map file), inspected, verified and
#    relocated, then run on an emulated node behind a native signal source.
# 2. Serial loopback: a node listening on a pty pair takes both modules over the wire and runs them.
# 3. The node firmware in C on QEMU virt: the same hexmigrate sends a module, lists it, and the
#    firmware's kernel runs it (its state, counters and a watch of its output).
# 4. The paper's section 6 experiment on two emulated robots: noise in the camera, ReFrESH
#    detects it, locates CamReader with Base Choice, chooses the Dehazer, migrates its image and
#    the task recovers. It ends with the summary table and where the report and plot are.
# 5. The same experiment across processes: the two robots' nodes and the servo emulator (which
#    serves its CAN buses itself) on loopback links, the manager in the command's process, in
#    lock-step virtual time.
# 6. The hardware half of ReFrESH: fog on the camera of a HexManipulator whose CPU cannot run
#    the software Dehazer; ReFrESH chooses the Dehazer on its FPGA, sends the two partial
#    bitstreams over the serial line and the frames stream through the fabric's median and
#    stretch (the transaction-level model of their Verilog); in process, then across processes.
#
# Usage: scripts/demo.sh VENV MODULE_BUILD_DIR
set -euo pipefail
venv=$1
build=$2
out="$build/hex"
mkdir -p "$out"
export PATH="$venv/bin:$PATH"

run() {
    echo "\$ $*"
    "$@"
    echo
}

for elf in "$build"/*.elf; do
    name=$(basename "$elf" .elf)
    echo "=== module $name ==="
    run hexmigrate pack "$elf" -o "$out/$name.hex"
    run hexmigrate pack --map "$build/$name.map" --bin "$build/$name.bin" -o "$out/$name.from-map.hex"
    run cmp "$out/$name.hex" "$out/$name.from-map.hex"
    echo "(the ELF route and the paper's map route wrote the same file)"
    echo
    run hexmigrate inspect "$out/$name.hex"
    run hexmigrate verify "$out/$name.hex"
    run hexmigrate relocate "$out/$name.hex" --base 0x00020000 -o "$out/$name.at-20000.bin"
    run hexmigrate relocate "$out/$name.hex" --base 0x00031000 -o "$out/$name.at-31000.bin"
    echo "32-bit words that differ between the two placements:"
    python - "$out/$name.at-20000.bin" "$out/$name.at-31000.bin" <<'PY'
import sys
first, second = (open(path, "rb").read() for path in sys.argv[1:])
print(f"  {'offset':>8}  {'at 0x20000':>10}  {'at 0x31000':>10}  difference")
for offset in range(0, len(first), 4):
    a, b = (int.from_bytes(x[offset : offset + 4], "little") for x in (first, second))
    if a != b:
        print(f"  0x{offset:06X}  0x{a:08X}  0x{b:08X}  {b - a:+#x}")
PY
    echo
done
echo "=== an emulated node runs both modules: signal -> gain (x2.5) -> moving_average ==="
run firmware-sim run --module "$out/gain.hex" --module "$out/moving_average.hex@0x08010000" \
    --native signal --set signal.shape=1 --set signal.amplitude=1000 --set signal.period_ms=200 \
    --set gain.k=0x28000 --wire signal.y=gain.x --wire gain.y=moving_average.x \
    --rate signal=100 --rate gain=100 --rate moving_average=100 --seconds 0.5
echo "module files written to $out/"

echo
echo "=== serial loopback: a node on a pty pair takes both modules over the wire and runs them ==="
node_log="$out/node.log"
node_pid=""
stop_node() {
    if [[ -n "$node_pid" ]] && kill -0 "$node_pid" 2>/dev/null; then
        kill "$node_pid" 2>/dev/null || true
        wait "$node_pid" 2>/dev/null || true
    fi
    node_pid=""
}
trap stop_node EXIT
trap 'stop_node; exit 130' INT TERM
node_command=(firmware-sim listen --listen pty --seconds 6 --show gain.y --show moving_average.y
    --native signal --set signal.shape=1 --set signal.amplitude=1000 --set signal.period_ms=3000
    --set gain.k=0x28000 --wire signal.y=gain.x --wire gain.y=moving_average.x)
echo "\$ ${node_command[*]} > $node_log 2>&1 &"
: >"$node_log" # there before the node writes to it, for the loop below to read
"${node_command[@]}" >>"$node_log" 2>&1 &
node_pid=$!
pty=""
for _ in $(seq 100); do # its first line names the pty: wait for it, 10 s at most
    pty=$(sed -n 's|^listening on \(/dev/pts/[0-9]*\) .*|\1|p' "$node_log" || true)
    if [[ -n "$pty" ]] || ! kill -0 "$node_pid" 2>/dev/null; then
        break
    fi
    sleep 0.1
done
if [[ -z "$pty" ]]; then
    echo "the node did not say where it listens:"
    cat "$node_log"
    exit 1
fi
echo "(the node listens on $pty)"
echo
run hexmigrate send "$out/gain.hex" --to "$pty" --mode hex --quiet
run hexmigrate send "$out/moving_average.hex" --to "$pty" --mode binary --quiet
run hexmigrate ls --to "$pty"
run hexmigrate ping --to "$pty"
echo "(waiting for the node to end: --seconds 6)"
node_status=0
wait "$node_pid" || node_status=$?
node_pid=""
echo "the node's output ($node_log):"
sed 's/^/  /' "$node_log"
if [[ $node_status -ne 0 ]]; then
    echo "the node exited with status $node_status"
    exit 1
fi

echo
echo "=== the node firmware in C on QEMU virt: the same hexmigrate sends, lists and runs a module ==="
qemu_log="$out/qemu-node.log"
qemu_command=(firmware-sim qemu --flash "$out/qemu-flash.img" --seconds 60)
echo "\$ ${qemu_command[*]} > $qemu_log 2>&1 &"
: >"$qemu_log"
"${qemu_command[@]}" >>"$qemu_log" 2>&1 &
node_pid=$!
pty=""
for _ in $(seq 300); do # the firmware is built first when missing: 30 s at most
    pty=$(sed -n 's|^listening on \(/dev/pts/[0-9]*\) .*|\1|p' "$qemu_log" || true)
    if [[ -n "$pty" ]] || ! kill -0 "$node_pid" 2>/dev/null; then
        break
    fi
    sleep 0.1
done
if [[ -z "$pty" ]]; then
    echo "the QEMU node did not say where it listens:"
    cat "$qemu_log"
    exit 1
fi
echo "(the QEMU node listens on $pty)"
echo
run hexmigrate send "$out/gain.hex" --to "$pty" --set gain.k=0x28000 --quiet
run hexmigrate ls --to "$pty"
run hexmigrate ps --verbose --to "$pty"
run hexmigrate watch --seconds 0.3 --period 0.1 --port gain.y --to "$pty"
stop_node
echo "the QEMU node's output ($qemu_log):"
sed 's/^/  /' "$qemu_log"

echo
echo "=== the paper's experiment: two robots, noise in the camera, ReFrESH repairs the task ==="
run python -m visual_servoing run --scenario paper --out "$(dirname "$build")/visual_servoing/paper"

echo
echo "=== the same experiment across processes: two nodes and the servos on loopback links, the manager here, lock-step time ==="
run python -m visual_servoing run --scenario paper --processes --out "$(dirname "$build")/visual_servoing/paper-processes"

echo
echo "=== the hardware half: fog, a CPU too small for the software Dehazer, the Dehazer on the FPGA chosen ==="
run python -m visual_servoing run --scenario fog-hardware --out "$(dirname "$build")/visual_servoing/fog-hardware"
run python -m visual_servoing run --scenario fog-hardware --processes --out "$(dirname "$build")/visual_servoing/fog-hardware-processes"
