#!/bin/bash
# The device-machine runs behind docs/opencl.md ("Measured"): conformance and timing of the
# OpenCL backend on an NVIDIA GPU and on PoCL. Run it from a folder holding test_opencl, vis
# and vis_clbench (built as docs/opencl.md says) and lib/ with libcmocka.so.0 and
# libOpenCL.so.1. Logs go to $OUT.
#   run_device.sh        everything (about 4 minutes on the lent H200)
#   run_device.sh 1      conformance, registers, gen:default (methods, draw list, batches)
#   run_device.sh 2      gen:city and gen:large, PoCL, vis bench with edits
#   run_device.sh 3      the questions left open on 2026-12-05 (docs/opencl.md, "Batches walk
#                        the cell grid"): batches of 256, AUTO (now dda) against stack, on three
#                        worlds; register caps and work-group shapes for the dda batches; the
#                        server's chunk passes on the GPU, dda (AUTO) against stack (needs vis
#                        built with Jansson and replays/NAME32.jsonl from
#                        `vis query --simulate 32 --ticks 256 --scene gen:NAME --seed 1`)
#   run_device.sh 5      the bucket cover masks (docs/opencl.md, "Bucket cover masks on the
#                        GPU", not yet run): test_opencl and the bit-for-bit comparison, then this tree
#                        against a parent's build in old/ (vis, vis_clbench), alternated, two
#                        rounds: batches of 256 on gen:default and gen:large, one view per
#                        camera of gen:default, and the methods' table on gen:default (this
#                        tree alone where old/ is missing)
#   run_device.sh 7      the 32-player replays (replays/ as for 3) with the chunk faces on the
#                        GPU and on 2 CPU threads, without a budget and with one face per tick
#                        (--chunk-face-budget 1, also with --chunk-move 4), two rounds
#   run_device.sh 8      the 32-player replays (replays/ as for 3) on 2 CPU threads of the
#                        host, this tree against a parent's build in old/ (vis), alternated,
#                        three rounds: defaults, one face per tick, and one face per tick with
#                        a call budget of 512 entity rays
#   run_device.sh 9      the 32-player replays with the chunk faces on the GPU at face budgets
#                        none, 4, 8 and 16, and on 2 CPU threads at one face per tick, two
#                        rounds; then which ticks of a GPU run (no budget) pass 1.8 ms
#   run_device.sh 10     tick 0 with the chunk faces on the GPU: this tree against a parent's
#                        build in old/vis, alternated, three rounds
#   run_device.sh 11     10 and 100 players (replays/NAME10.jsonl, NAME100.jsonl from
#                        `vis query --simulate 10|100 --ticks 256 --scene gen:NAME --seed 1`):
#                        the chunk faces on the GPU (no face budget) and on 2 CPU threads (no
#                        budget, and one face per tick), two rounds
#   run_device.sh 12     the 32-player replays on 2 CPU threads at face budgets none, 1, 2
#                        and 4, three rounds
#   run_device.sh 13     one view against its cost on a full device (docs/opencl.md, "Bucket
#                        offsets read behind the cover masks; one view against a full
#                        device"): registers and PTX of every program, then
#                        gen:default's views alone and in batches of 32 copies (--copies 32)
#                        under the single-view knobs (persistent walk, 8x4, 16x8 and 4x4
#                        groups, register caps 64 and 80), alternated, two rounds; gen:large
#                        once with the defaults
#   run_device.sh 14     one ray in parts whose pieces share their best hit (a build of the
#                        reverted parts code with that change in parts/): conformance at K = 2
#                        and 4, then one view per camera at K = 1, 2 and 4, alternated, two
#                        rounds, on gen:default and gen:large
#   run_device.sh 15     batch shapes and caps on this tree: batches of 256 with draw lists in
#                        8x4 (the default), 4x8, 16x2 and 32x1 groups and with register caps
#                        68 and 76, alternated, two rounds on gen:default, one on gen:large
#   run_device.sh 16     this tree against a parent's build in old/ and candidates' builds in
#                        b2/ and b3/ (test_opencl, vis_clbench): test_opencl, then batches of
#                        256 on gen:default and gen:large and one view per camera of
#                        gen:default, the builds alternated, two rounds; then test_opencl of
#                        the candidates and the bit-for-bit comparison of every build
#   run_device.sh 17     batches of 256 with draw lists on gen:default and gen:large, this
#                        tree against a parent's build in old/, alternated, two rounds
#   run_device.sh 18     the content box in the cell map with one plane walk (a build of
#                        70a032e in b2/) and persistent groups that ask for their next tile
#                        one tile ahead (b3/) and the dda walk prefetching the next cell's map
#                        entry (b4/), and both of the last two together (b5/), against this
#                        tree, alternated, two rounds: batches of 256 on gen:default (all
#                        five), one view per camera of gen:default (tree, b2, b4), batches
#                        on gen:large; then the dda program's registers and spills under
#                        ptxas (tree and b2), uncapped and at the batch cap of 72, and the
#                        candidates' bit-for-bit comparisons
#   run_device.sh 19     the bit-for-bit comparisons of b3/, b4/, b5/ and b2/ alone (what phase 18
#                        leaves when it runs out of time)
#   run_device.sh 20     the plane walk's bucket visit as a function of its own (2026-12-07,
#                        shared with the CPU's label walk): test_opencl and the bit-for-bit
#                        comparison, then this tree against a parent's build in old/,
#                        alternated, two rounds: batches of 256 on gen:default and gen:large,
#                        one view per camera of gen:default
#   run_device.sh 21     the draw list without the counts' fill and with one read for one view
#                        (2026-12-07, docs/opencl.md): this tree against a parent's build in
#                        old/ and a candidate's in b2/ (vis_clbench), alternated, two rounds:
#                        one view per camera of gen:default with its draw list (50
#                        repetitions) and batches of 256; between the rounds gen:large's views
#                        and batches, one round, with a second candidate's build in b3/ too;
#                        then test_opencl and the bit-for-bit comparison of this tree, and
#                        test_opencl of b2/ (each build taking part if there)
#   run_device.sh 4      the questions of 2026-12-05, evening (docs/opencl.md, "Work-group
#                        shape and register cap for batches"): the dda batches of 256 with
#                        8x8 and 8x4 work-groups and register caps of 72 (the default) and
#                        64, alternated, two rounds, on gen:default and gen:large; then the
#                        32-player replays on both backends (replays/ as for 3)
cd "$(dirname "$0")"
mkdir -p /etc/OpenCL/vendors && echo libnvidia-opencl.so.1 > /etc/OpenCL/vendors/nvidia.icd
export LD_LIBRARY_PATH=$PWD/lib:$LD_LIBRARY_PATH
O=${OUT:-/tmp/out}; mkdir -p "$O"
PHASE=${1:-all}
query_ms() { # query_ms VIS SCENE REPLAY OPTIONS...: the summary's chunk rays and ms per tick
  local c=$1 s=$2 r=$3; shift 3
  $c query --scene gen:$s --replay replays/$r.jsonl --threads 2 "$@" --json 2>&1 |
    grep -o '"chunk_rays_per_tick":[0-9.]*\|"ms_per_tick":{[^}]*}' | tr '\n' ' '
}
compile_gpu() { # one run first, so that the driver's cache holds the programs the timed runs use
  ./vis query --scene gen:maze --replay replays/$1.jsonl --threads 2 --backend opencl --json > /dev/null 2>&1
}
# The A/B helpers take build folders: . (this tree, shown as "new"), old/ (a parent's build),
# b2/ to b5/ (candidates); a folder without the binary is left out.
build_name() { [ "$1" = . ] && echo new || echo "$1"; }
gpu_test() { # gpu_test DIR LIMIT_S: test_opencl of that build
  [ -x $1/test_opencl ] || return 0
  local n=${1#.}
  timeout $2 $1/test_opencl > "$O/test_gpu${n:+_$n}.log" 2>&1; echo "$(build_name $1) test_opencl rc=$?"
  grep -E "PASSED|FAILED|cameras compared" "$O/test_gpu${n:+_$n}.log"
}
gpu_conformance() { # gpu_conformance DIR: the bit-for-bit comparison of that build
  [ -x $1/vis_clbench ] || return 0
  local n=${1#.}
  timeout 150 $1/vis_clbench --device NVIDIA --cameras 20 --reps 5 --drawlist 1 --batch 1,7,256 \
    > "$O/conf${n:+_$n}.log" 2>&1
  echo "$(build_name $1) conformance rc=$?"; grep -E "RESULT|mismatch" "$O/conf${n:+_$n}.log" | tail -3
}
batch_rounds_on() { # batch_rounds_on SCENE DIR...: batches of 256 with draw lists, two rounds
  local s=$1; shift
  for round in 1 2; do for b in "$@"; do
    [ -x $b/vis_clbench ] || continue
    echo "$s batch 256, $(build_name $b), round $round: $(timeout 60 $b/vis_clbench --scene $s --device NVIDIA \
      --conformance 0 --passes 0 --drawlist 1 --reps 5 --batch 256 2>&1 | grep -E '^ +256' | tr -s ' ')"
  done; done
}
batch_rounds() { # batch_rounds DIR...: batch_rounds_on gen:default, then gen:large
  batch_rounds_on gen:default "$@"; batch_rounds_on gen:large "$@"
}
view_rounds() { # view_rounds DIR...: one view per camera of gen:default, two rounds
  for round in 1 2; do for b in "$@"; do
    [ -x $b/vis_clbench ] || continue
    local n=$(build_name $b)
    timeout 60 $b/vis_clbench --device NVIDIA --conformance 0 --drawlist 1 --reps 10 > "$O/views_${n}_$round.log" 2>&1
    echo "gen:default one view, $n, round $round (rc=$?):"
    grep -E "^(default|ground|horizon|overview|topdown|walk-)" "$O/views_${n}_$round.log"
  done; done
}
nvidia-smi --query-gpu=name,driver_version,memory.total,clocks.sm --format=csv
date -u

if [ "$PHASE" = all ] || [ "$PHASE" = 1 ]; then
  echo "== test_opencl on the default device (the first GPU)"
  timeout 150 ./test_opencl > "$O/test_gpu.log" 2>&1; echo "test_opencl rc=$?"
  grep -E "PASSED|FAILED|cameras compared|traversal methods" "$O/test_gpu.log"

  echo "== registers and stack frame per method program (ptxas via -cl-nv-verbose)"
  ./vis_clbench --nv-verbose 1 > "$O/nv_verbose.log" 2>&1
  VIS_OPENCL_BUILD_OPTIONS=-cl-nv-maxrregcount=64 ./vis_clbench --nv-verbose 1 >> "$O/nv_verbose.log" 2>&1
  grep -E "VIS_TRAVERSAL_ONLY|Function properties for vis_trace_kernel|Used [0-9]+ registers|stack frame" \
    "$O/nv_verbose.log" | grep -A3 "VIS_TRAVERSAL_ONLY" | head -80

  echo "== gen:default: conformance, passes, Tables 3/5, draw list, batches, edits"
  timeout 230 ./vis_clbench --device NVIDIA --cameras 20 --reps 50 --methods 1 --drawlist 1 \
    --batch 1,16,64,256 > "$O/bench_default.log" 2>&1; echo "vis_clbench rc=$?"
  cat "$O/bench_default.log"

  for t in 16x8 8x4; do
    echo "== gen:default, work-groups $t: draw lists, batches of 256"
    VIS_OPENCL_TILE=$t timeout 60 ./vis_clbench --device NVIDIA --conformance 0 --passes 0 --drawlist 1 --reps 20 \
      --batch 256 2>&1 | grep -E "^default|^walk-2|^ +256"
  done

  echo "== gen:default, 64 registers at most (-cl-nv-maxrregcount=64)"
  VIS_OPENCL_BUILD_OPTIONS=-cl-nv-maxrregcount=64 timeout 80 ./vis_clbench --device NVIDIA --conformance 0 \
    --passes 0 --methods 1 --drawlist 1 --reps 20 --batch 256 > "$O/bench_default_r64.log" 2>&1
  echo "rc=$?"; cat "$O/bench_default_r64.log"
fi

if [ "$PHASE" = all ] || [ "$PHASE" = 2 ]; then
  for s in gen:city gen:large; do
    echo "== $s: Tables 3/5, draw list, batches"
    timeout 150 ./vis_clbench --scene $s --device NVIDIA --conformance 0 --passes 0 --methods 1 --drawlist 1 \
      --reps 20 --batch 256 > "$O/bench_${s#gen:}.log" 2>&1; echo "rc=$?"
    cat "$O/bench_${s#gen:}.log"
  done
  echo "== gen:default, 40 registers at most (-cl-nv-maxrregcount=40): Tables 3/5 only"
  VIS_OPENCL_BUILD_OPTIONS=-cl-nv-maxrregcount=40 timeout 60 ./vis_clbench --device NVIDIA --conformance 0 \
    --passes 0 --methods 1 --reps 20 > "$O/bench_default_r40.log" 2>&1; echo "rc=$?"; cat "$O/bench_default_r40.log"
  echo "== PoCL on the host's cores: Tables 3/5 at 128x128"
  timeout 90 ./vis_clbench --device pocl --conformance 0 --passes 0 --methods 1 --reps 3 --size 128 \
    > "$O/bench_pocl.log" 2>&1; echo "rc=$?"; cat "$O/bench_pocl.log"
  echo "== vis bench with single-voxel edits on the GPU"
  timeout 60 ./vis bench --scene gen:default --backend opencl --frames 10 --edits 200 > "$O/vis_bench_edits.log" 2>&1
  echo "rc=$?"; tail -30 "$O/vis_bench_edits.log"
fi
if [ "$PHASE" = 3 ]; then
  for s in gen:default gen:city gen:large; do for round in 1 2; do for t in 0 1; do
    echo "$s batch 256, traversal $t (0 AUTO, 1 stack), round $round: $(timeout 90 ./vis_clbench --scene $s \
      --device NVIDIA --conformance 0 --passes 0 --drawlist 1 --reps 5 --batch 256 --traversal $t 2>&1 | grep -E '^ +256' | tr -s ' ')"
  done; done; done
  for R in 56 64 72 80 96; do
    echo "gen:default dda batch, -cl-nv-maxrregcount=$R: $(VIS_OPENCL_BUILD_OPTIONS=-cl-nv-maxrregcount=$R timeout 60 \
      ./vis_clbench --device NVIDIA --conformance 0 --passes 0 --drawlist 1 --reps 5 --batch 256 2>&1 | grep -E '^ +256' | tr -s ' ')"
  done
  for T in 8x4 16x4; do
    echo "gen:default dda batch, tile $T: $(VIS_OPENCL_TILE=$T timeout 60 ./vis_clbench --device NVIDIA --conformance 0 \
      --passes 0 --drawlist 1 --reps 5 --batch 256 2>&1 | grep -E '^ +256' | tr -s ' ')"
  done
  compile_gpu maze32
  for round in 1 2; do for s in city default maze; do for t in auto stack; do
    echo "query $s --chunk-traversal $t round $round: $(./vis query --scene gen:$s --replay replays/${s}32.jsonl \
      --threads 2 --backend opencl --chunk-traversal $t --json --out "$O/q_${s}_${t}_$round.jsonl" 2>&1 | head -c 400)"
  done; done; done
  for s in city default maze; do # the lists must not depend on the method
    cmp -s <(sed 's/"ms":[0-9.]*,//' "$O/q_${s}_auto_1.jsonl") <(sed 's/"ms":[0-9.]*,//' "$O/q_${s}_stack_1.jsonl") &&
      echo "$s: the same lists with both methods" || echo "$s: THE LISTS DIFFER"
  done
  rm -f "$O"/q_*.jsonl
fi
if [ "$PHASE" = 4 ]; then
  echo "== test_opencl"
  timeout 150 ./test_opencl > "$O/test_gpu.log" 2>&1; echo "test_opencl rc=$?"
  grep -E "PASSED|FAILED|cameras compared" "$O/test_gpu.log"
  for s in gen:default gen:large; do for round in 1 2; do for T in 8x8 8x4; do for R in 72 64; do
    echo "$s batch 256, tile $T, maxrregcount $R, round $round: $(VIS_OPENCL_TILE=$T \
      VIS_OPENCL_BUILD_OPTIONS=-cl-nv-maxrregcount=$R timeout 60 ./vis_clbench --scene $s --device NVIDIA \
      --conformance 0 --passes 0 --drawlist 1 --reps 5 --batch 256 2>&1 | grep -E '^ +256' | tr -s ' ')"
  done; done; done; done
  compile_gpu maze32
  for round in 1 2; do for s in city default maze; do for b in opencl cpu old-cpu; do
    v=./vis; [ $b = old-cpu ] && { [ -x old/vis ] || continue; v=old/vis; } # old/: a parent's build
    echo "query $s --backend $b round $round: $($v query --scene gen:$s --replay replays/${s}32.jsonl \
      --threads 2 --backend ${b#old-} --json 2>&1 | grep -o '"ms_per_tick":{[^}]*}')"
  done; done; done
fi
if [ "$PHASE" = 5 ]; then
  echo "== test_opencl"
  gpu_test . 150
  gpu_conformance .
  batch_rounds . old
  view_rounds . old
  for b in . old; do
    [ -x $b/vis_clbench ] || continue
    n=$(build_name $b)
    timeout 90 $b/vis_clbench --device NVIDIA --conformance 0 --passes 0 --methods 1 --reps 10 > "$O/methods_$n.log" 2>&1
    echo "gen:default methods, $n (rc=$?):"; cat "$O/methods_$n.log" | tail -25
  done
fi
if [ "$PHASE" = 7 ]; then
  compile_gpu maze32
  for round in 1 2; do for s in city default maze; do for b in opencl cpu; do
    for o in "" "--chunk-face-budget 1" "--chunk-move 4 --chunk-face-budget 1"; do
      echo "query $s --backend $b [$o] round $round: $(./vis query --scene gen:$s --replay replays/${s}32.jsonl \
        --threads 2 --backend $b $o --json 2>&1 | grep -o '"chunk_rays_per_tick":[0-9.]*\|"ms_per_tick":{[^}]*}' | tr '\n' ' ')"
    done
  done; done; done
fi
if [ "$PHASE" = 8 ]; then
  for round in 1 2 3; do for s in city default maze; do
    for o in "" "--chunk-face-budget 1" "--chunk-face-budget 1 --budget 512"; do for b in new old; do
      c=./vis; [ $b = old ] && c=old/vis
      echo "query $s [$o] $b round $round: $($c query --scene gen:$s --replay replays/${s}32.jsonl --threads 2 \
        --backend cpu $o --json 2>&1 | grep -o '"unchecked_per_tick":[0-9.]*\|"ms_per_tick":{[^}]*}' | tr '\n' ' ')"
    done; done
  done; done
fi

if [ "$PHASE" = 9 ]; then
  compile_gpu maze32
  for round in 1 2; do for s in city default maze; do
    for o in "opencl 0" "opencl 4" "opencl 8" "opencl 16" "cpu 1"; do set -- $o
      echo "query $s $1 fb $2 round $round: $(query_ms ./vis $s ${s}32 --backend $1 --chunk-face-budget $2)"
    done
  done; done
  for s in city default maze; do
    ./vis query --scene gen:$s --replay replays/${s}32.jsonl --threads 2 --backend opencl --out "$O/ticks_$s.jsonl" \
      --json > /dev/null 2>&1
    echo "$s: ticks over 1.8 ms (tick, ms, entity rays, chunk rays): $(python3 -c "
import json, sys
rows = [json.loads(l) for l in open(sys.argv[1]) if l.startswith('{\"tick')]
print([(x['tick'], round(x['ms'], 2), x['entity_rays'], x['chunk_rays']) for x in rows if x['ms'] > 1.8])
" "$O/ticks_$s.jsonl")"
  done
fi
if [ "$PHASE" = 10 ]; then
  compile_gpu maze32
  for round in 1 2 3; do for s in city default maze; do for b in new old; do
    c=./vis; [ $b = old ] && c=old/vis
    $c query --scene gen:$s --replay replays/${s}32.jsonl --threads 2 --backend opencl --out "$O/t.jsonl" --json \
      2>&1 | grep -o '"ms_per_tick":{[^}]*}' > "$O/s.txt"
    echo "$s $b round $round: $(cat "$O/s.txt") tick0 $(head -c 300 "$O/t.jsonl" | grep -o '"ms":[0-9.]*')"
  done; done; done
fi
if [ "$PHASE" = 11 ]; then
  compile_gpu maze10
  for round in 1 2; do for p in 10 100; do for s in city default maze; do
    for o in "opencl 0" "cpu 0" "cpu 1"; do set -- $o
      echo "query $s$p $1 fb $2 round $round: $(query_ms ./vis $s $s$p --backend $1 --chunk-face-budget $2)"
    done
  done; done; done
fi
if [ "$PHASE" = 12 ]; then
  for round in 1 2 3; do for s in city default maze; do for fb in 0 1 2 4; do
    echo "query $s fb $fb round $round: $(query_ms ./vis $s ${s}32 --backend cpu --chunk-face-budget $fb)"
  done; done; done
fi

if [ "$PHASE" = 13 ]; then
  mkdir -p "$O/ptx"
  VIS_CLBENCH_PTX="$O/ptx" ./vis_clbench --nv-verbose 1 > "$O/nv_verbose.log" 2>&1
  VIS_OPENCL_BUILD_OPTIONS=-cl-nv-maxrregcount=72 ./vis_clbench --nv-verbose 1 > "$O/nv_verbose72.log" 2>&1
  grep -E "VIS_TRAVERSAL_ONLY=9|Used [0-9]+ registers" "$O/nv_verbose.log" | grep -A3 "ONLY=9" | head -12
  single() { # single LABEL ENV...: one view alone and in 32 copies, then the batch of 256
    local l=$1; shift
    echo "== $l"
    env "$@" timeout 120 ./vis_clbench --device NVIDIA --conformance 0 --passes 0 --drawlist 1 --reps 10 \
      --batch 256 --copies 32 2>&1 | sed -n '/^view /,/^ *256 /p' | grep -v "^batches\|^ *views"
  }
  for round in 1 2; do
    single "defaults, round $round" X=0
    single "persistent, round $round" VIS_OPENCL_WALK=persistent
    single "8x4, round $round" VIS_OPENCL_TILE=8x4
    single "16x8, round $round" VIS_OPENCL_TILE=16x8
    single "4x4, round $round" VIS_OPENCL_TILE=4x4
    single "cap 64, round $round" VIS_OPENCL_BUILD_OPTIONS=-cl-nv-maxrregcount=64
    single "cap 80, round $round" VIS_OPENCL_BUILD_OPTIONS=-cl-nv-maxrregcount=80
  done
  echo "== gen:large, defaults"
  timeout 150 ./vis_clbench --scene gen:large --device NVIDIA --conformance 0 --passes 0 --drawlist 1 --reps 10 \
    --batch 256 --copies 32 2>&1 | sed -n '/^view /,/^ *256 /p'
fi

if [ "$PHASE" = 14 ]; then
  for K in 2 4; do
    VIS_OPENCL_PARTS=$K timeout 120 parts/vis_clbench --device NVIDIA --cameras 10 --reps 2 --batch 1 > "$O/parts_conf$K.log" 2>&1
    echo "parts K=$K conformance rc=$?: $(grep -E "RESULT|mismatches" "$O/parts_conf$K.log" | tail -2 | tr '\n' ' ')"
  done
  for s in gen:default gen:large; do for round in 1 2; do for K in 1 2 4; do
    echo "== $s parts K=$K round $round"
    VIS_OPENCL_PARTS=$K timeout 120 parts/vis_clbench --scene $s --device NVIDIA --conformance 0 --passes 0 \
      --drawlist 1 --reps 10 --batch 1 2>&1 | sed -n '/^view /,/^walk-5/p'
  done; done; done
fi

if [ "$PHASE" = 16 ]; then
  gpu_test . 300
  batch_rounds . old b2 b3
  view_rounds . old b2 b3
  for d in b2 b3; do gpu_test $d 300; done
  for d in . b2 b3; do gpu_conformance $d; done
fi
if [ "$PHASE" = 18 ]; then
  # What the goal asks first (batches on gen:default), then the rest, in case time runs out.
  batch_rounds_on gen:default . b2 b3 b4 b5
  view_rounds . b2 b4
  batch_rounds_on gen:large . b2 b3 b4 b5
  for d in . b2; do for cap in "" -cl-nv-maxrregcount=72; do
    echo "== ptxas, $(build_name $d), dda program, options '$cap'"
    VIS_CLBENCH_NV_ONLY=9 VIS_OPENCL_BUILD_OPTIONS=$cap timeout 60 $d/vis_clbench --nv-verbose 1 2>&1 |
      grep -E "Function properties|spill|Used [0-9]+ registers"
  done; done
fi
if [ "$PHASE" = 18 ] || [ "$PHASE" = 19 ]; then
  for d in b3 b4 b5 b2; do gpu_conformance $d; done
fi
if [ "$PHASE" = 20 ]; then
  gpu_test . 150
  batch_rounds . old
  view_rounds . old
  gpu_conformance .
fi
if [ "$PHASE" = 21 ]; then
  lists() { # lists DIR SCENE REPS ROUND: one view per camera with its draw list, and batches of 256
    local n=$(build_name $1)
    timeout 90 $1/vis_clbench --scene $2 --device NVIDIA --cameras 0 --conformance 0 --passes 0 --drawlist 1 \
      --reps $3 --batch 256 > "$O/lists_${n}_${2#gen:}_$4.log" 2>&1
    echo "$2 draw lists, $n, round $4 (rc=$?):"
    grep -E "^(default|ground|overview|topdown|walk-)|^ +256" "$O/lists_${n}_${2#gen:}_$4.log"
  }
  # The timings first (what a short device lease most needs), then the tests.
  for b in . old b2; do [ -x $b/vis_clbench ] && lists $b gen:default 50 1; done
  for b in . b3 old b2; do [ -x $b/vis_clbench ] && lists $b gen:large 20 1; done
  for b in . old b2; do [ -x $b/vis_clbench ] && lists $b gen:default 50 2; done
  gpu_test . 240
  gpu_conformance .
  gpu_test b2 240
fi
if [ "$PHASE" = 17 ]; then
  batch_rounds . old
fi
if [ "$PHASE" = 15 ]; then
  for s in gen:default gen:default gen:large; do
    for e in X=0 VIS_OPENCL_TILE=4x8 VIS_OPENCL_TILE=16x2 VIS_OPENCL_TILE=32x1 \
             VIS_OPENCL_BUILD_OPTIONS=-cl-nv-maxrregcount=68 VIS_OPENCL_BUILD_OPTIONS=-cl-nv-maxrregcount=76; do
      echo "$s $e: $(env $e timeout 90 ./vis_clbench --scene $s --device NVIDIA --conformance 0 --passes 0 \
        --drawlist 1 --reps 3 --batch 256 2>&1 | grep -E '^ +256' | tr -s ' ')"
    done
  done
fi

date -u
