#!/bin/bash
# The device-machine runs behind docs/opencl.md ("Measured"): conformance and timing of the
# OpenCL backend on an NVIDIA GPU and on PoCL. Run it from a folder holding test_opencl, vis
# and vis_clbench (built as docs/opencl.md says) and lib/libcmocka.so.0. Logs go to $OUT.
cd "$(dirname "$0")"
mkdir -p /etc/OpenCL/vendors && echo libnvidia-opencl.so.1 > /etc/OpenCL/vendors/nvidia.icd
export LD_LIBRARY_PATH=$PWD/lib:$LD_LIBRARY_PATH
O=${OUT:-/tmp/out}; mkdir -p "$O"
nvidia-smi --query-gpu=name,driver_version,memory.total,clocks.sm --format=csv
(command -v clinfo >/dev/null && clinfo -l) || echo "no clinfo"

echo "== test_opencl on the default device (the first GPU)"
timeout 170 ./test_opencl 2>&1 | tee "$O/test_gpu.log" | grep -vE "^\[ RUN"

echo "== conformance and timing on the GPU"
timeout 230 ./vis_clbench --device NVIDIA --cameras 60 --reps 200 --batch 1,16,64,256 2>&1 | tee "$O/bench_gpu.log"
./vis_clbench --nv-verbose 1 2>&1 | tee "$O/nv_verbose.log" | grep -E "registers|stack frame"
for t in 8x8 16x8 16x16 32x4 32x8; do
  echo "== work-groups $t"
  VIS_OPENCL_TILE=$t timeout 60 ./vis_clbench --device NVIDIA --cameras 0 --reps 100 --batch 64,256 > "$O/bench_gpu_$t.log" 2>&1
  grep -E "conformance|^default +0|^ +256 |RESULT" "$O/bench_gpu_$t.log"
done

echo "== the CLI: GPU, CPU backend, PoCL"
timeout 60 ./vis cull --scene gen:default --backend opencl --repeat 200 --json 2>&1 | tee "$O/cli_gpu.json"
timeout 40 ./vis cull --scene gen:default --backend cpu --repeat 20 --json 2>&1 | tee "$O/cli_cpu.json"
VIS_OPENCL_DEVICE=pocl timeout 40 ./vis cull --scene gen:default --backend opencl --repeat 20 --json 2>&1 | tee "$O/cli_pocl.json"

echo "== PoCL on the host's cores"
timeout 150 ./vis_clbench --device pocl --cameras 0 --reps 10 --batch 16 2>&1 | tee "$O/bench_pocl.log"
