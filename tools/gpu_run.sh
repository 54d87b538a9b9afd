#!/usr/bin/env bash
# Runs the DDGI benchmarks and evaluations on the GPU machine (the workplace's `device` tool), from
# a release binary built here and carried as dist/game_demo with the Vulkan loader packages in .gl/
# (see BENCHMARKS.md). Everything lands in $OUT/results$TAG.tgz.
set -u
for f in .gl/*.deb; do dpkg -x "$f" /; done
ldconfig
if ! ls /usr/share/vulkan/icd.d/*.json /etc/vulkan/icd.d/*.json >/dev/null 2>&1; then
    export VK_DRIVER_FILES=/usr/local/nvidia/share/vulkan/icd.d/nvidia_icd.json
fi
export WGPU_BACKEND=vulkan RUST_LOG=${RUST_LOG:-warn}
# The shared folder (Kenney's models for the level) does not travel with the checkout: carry a copy
# as .shared/ (`mkdir -p .shared/assets && cp -r ../shared/assets/kenney_fps .shared/assets/`, and
# `carry: [".shared"]`); binaries find it through DDGI_SHARED_DIR, older ones in ../shared beside
# the checkout they were built from (/work/main or /tmp/base). Without it the level has its own props.
if [ -d .shared ]; then
    export DDGI_SHARED_DIR=$PWD/.shared
    for d in /work/shared /shared; do mkdir -p "$d" && cp -r .shared/. "$d/" 2>/dev/null; done
else
    echo "no .shared/ carried: the level is built from its own props" >&2
fi
# B: the binary (default dist/game_demo); TAG: a suffix for the results of this call, so that
# several binaries can be compared in one session.
B=${B:-dist/game_demo}
# Binaries may travel gzipped (dist/NAME.gz): unpacked here once.
for z in dist/*.gz; do [ -e "$z" ] && [ ! -e "${z%.gz}" ] && gunzip -k "$z" && chmod +x "${z%.gz}"; done
TAG=${TAG:-}
# CACHE: where the path-traced references are kept (default one folder per TAG; name one to share
# them between calls of the same binary).
CACHE=${CACHE:-/tmp/cache$TAG}
R=$OUT/r$TAG
mkdir -p "$R"
nvidia-smi --query-gpu=name,driver_version --format=csv > "$R/gpu.txt" 2>&1
date -u > "$R/date.txt"
# Viewpoints along the open world's tour (scenes::open::tour_at at D metres, looking ahead and down).
declare -A VIEWS=([20]="6.75,1.70,19.69 11.74,0.70,28.36" [80]="37.28,1.14,71.33 42.69,0.14,79.74" [300]="155.99,1.18,256.55 161.36,0.18,264.99")
# Reports, tables and plots only (the per-configuration strips would pass the 16 MiB a file that
# comes back).
# FIGURES=PATTERN: every PNG of the steps whose path contains PATTERN (e.g. an eval's strips).
# STRIPS=1: the views' strips too (direct | method | reference | FLIP map, 256 px high), and the
# peer steps' strips (its rows side by side, the reference last).
# Packed after every step, so that a call cut off by its time limit still brings back the steps
# that finished.
pack() {
    (cd "$OUT" && { find "r$TAG" -name '*.md' -o -name '*.txt' -o -name '*.csv' -o -name '*.json' -o -name 'error_vs_time.png' -o -name 'time_series.png' -o -name 'image.png'; [ -n "${STRIPS:-}" ] && find "r$TAG" -path '*view-*' -name 'ddgi*.png'; [ -n "${SHOTS:-}" ] && find "r$TAG" -path '*shots-*' -name 'frame_*.png'; [ -n "${FIGURES:-}" ] && find "r$TAG" -path "*${FIGURES}*" -name '*.png'; [ -n "${STRIPS:-}" ] && find "r$TAG" -path '*peer_*' -name '*.png'; } | tar czf "results$TAG.tgz.part" -T - && mv "results$TAG.tgz.part" "results$TAG.tgz")
}
run() { # name, command...
    local name=$1
    shift
    local t0=$(date +%s)
    timeout 300 "$@" > "$R/$name.txt" 2>&1
    echo "$name: exit $? in $(( $(date +%s) - t0 )) s" | tee -a "$R/summary.txt"
    pack
}
for step in "$@"; do
    case $step in
    bench_*) scene=${step#bench_}; run "$step" $B bench ddgi --scene "$scene" --iterations 10 ;;
    # benchgrid_SCENE: DDGI's full probe update with its per-pass times at the cells BENCH_ARGS asks
    # for (e.g. "--probes 8,8,8 --rays 8,32,128").
    benchgrid_*) scene=${step#benchgrid_}; run "$step" $B bench ddgi --scene "$scene" --iterations 15 ${BENCH_ARGS:-} ;;
    eval_*) scene=${step#eval_}; run "$step" $B eval --scene "$scene" --width 256 --height 256 --reference-spp 4096 --experiments --out "$R/$step" --cache $CACHE ;;
    # evalplain_SCENE: the evaluation without the experiments (the configurations every binary has).
    evalplain_*) scene=${step#evalplain_}; run "$step" $B eval --scene "$scene" --width 256 --height 256 --reference-spp ${SPP:-4096} --out "$R/$step" --cache $CACHE ;;
    # camera_SCENE-AO: the camera path at 1920x1080 as the demo shows it (DDGI, TAA, contact
    # occlusion with AO rays a pixel, AgX, auto-exposure), 120 frames: timings.json per pass.
    camera_*) IFS=- read -r scene ao <<< "${step#camera_}"; run "$step" $B render --scene "$scene" --mode ddgi --width 1920 --height 1080 --contact-occlusion "$ao" --display-transform agx --auto-exposure --out "$R/$step" ;;
    # camerafull_SCENE-AO: the same with the contact occlusion traced at every pixel (not half resolution).
    camerafull_*) IFS=- read -r scene ao <<< "${step#camerafull_}"; run "$step" $B render --scene "$scene" --mode ddgi --width 1920 --height 1080 --contact-occlusion "$ao" --contact-occlusion-full-resolution --display-transform agx --auto-exposure --out "$R/$step" ;;
    # shots-FRAMES-EVERY: the demo's scripted walk at 1920x1080, a PNG every EVERY frames.
    shots-*) IFS=- read -r _ frames every <<< "$step"; run "$step" $B play --headless --width 1920 --height 1080 --frames "$frames" --every "$every" --out "$R/$step" ;;
    # SERIES_ARGS: more eval options for every series step (e.g. "--hysteresis-exponent 0.5").
    series_*) scene=${step#series_}; run "$step" $B eval --scene "$scene" --time-series --width 256 --height 256 --reference-spp 4096 --out "$R/$step" --cache $CACHE ${SERIES_ARGS:-} ;;
    # seriesrest-SCENE-FRAMES-ERROR: the time series with other resting parameters for the adaptive budgets.
    # seriesgrid-SCENE-X,Y,Z-FRAMES-ERROR: the same on another probe grid.
    seriesgrid-*) IFS=- read -r _ scene grid rest error <<< "$step"; run "$step" $B eval --scene "$scene" --time-series --width 256 --height 256 --reference-spp 4096 --probes "$grid" --rest-frames "$rest" --rest-error "$error" --out "$R/$step" --cache $CACHE ${SERIES_ARGS:-} ;;
    seriesrest-*) IFS=- read -r _ scene rest error <<< "$step"; run "$step" $B eval --scene "$scene" --time-series --width 256 --height 256 --reference-spp 4096 --rest-frames "$rest" --rest-error "$error" --out "$R/$step" --cache $CACHE ${SERIES_ARGS:-} ;;
    # evalcascades-SCENE-N: the still evaluation with N camera-following cascades for every DDGI
    # configuration (N = 0: one volume); evalplain_SCENE is the same at the scene-fitted rule.
    evalcascades-*) IFS=- read -r _ scene n <<< "$step"; run "$step" $B eval --scene "$scene" --width 256 --height 256 --reference-spp ${SPP:-4096} --cascades "$n" --out "$R/$step" --cache $CACHE ;;
    # shot_SCENE: a screenshot of SCENE lit by DDGI at 1280x720 (TAA, AgX, auto-exposure, 240 frames).
    shot_*) scene=${step#shot_}; run "$step" $B render --scene "$scene" --mode ddgi --width 1280 --height 720 --frames 240 --display-transform agx --auto-exposure --out "$R/$step" ;;
    # traceopaque_SCENE: trace_SCENE with every material opaque (--opaque): what its alpha masks cost.
    traceopaque_*) scene=${step#traceopaque_}; run "$step" $B bench trace --scene "$scene" --iterations 15 --no-flat-rebuild --opaque ;;
    trace_*) scene=${step#trace_}; run "$step" $B bench trace --scene "$scene" --iterations 15 --no-flat-rebuild ;;
    # tracecoh_SCENE: the same with each probe's rays in coherent order (a warp's rays in one patch of the sphere).
    tracecoh_*) scene=${step#tracecoh_}; run "$step" $B bench trace --scene "$scene" --iterations 15 --no-flat-rebuild --ray-order coherent ;;
    # tracewg_SCENE-SIZE: the same with SIZE threads a workgroup (TRACE_ARGS: more options, e.g. "--ray-order coherent").
    tracewg_*) IFS=- read -r scene size <<< "${step#tracewg_}"; run "$step" $B bench trace --scene "$scene" --iterations 15 --no-flat-rebuild --workgroup-size "$size" ${TRACE_ARGS:-} ;;
    # tracepers_SCENE-GROUPS: the persistent kernel with GROUPS workgroups (TRACE_ARGS as above).
    tracepers_*) IFS=- read -r scene groups <<< "${step#tracepers_}"; run "$step" $B bench trace --scene "$scene" --iterations 15 --no-flat-rebuild --persistent-groups "$groups" ${TRACE_ARGS:-} ;;
    # tracestack_SCENE-K: the thread-a-ray kernel with its stack in function memory (the engine's) and
    # with the top K entries of each thread's stack in workgroup memory, timed in the same run
    # (TRACE_ARGS as above).
    tracestack_*) IFS=- read -r scene k <<< "${step#tracestack_}"; run "$step" $B bench trace --scene "$scene" --iterations 15 --no-flat-rebuild --shared-stack "$k" ${TRACE_ARGS:-} ;;
    # tracestackpers_SCENE-K: the same comparison for the best persistent kernel found (4,224
    # workgroups of 128, coherent order).
    tracestackpers_*) IFS=- read -r scene k <<< "${step#tracestackpers_}"; run "$step" $B bench trace --scene "$scene" --iterations 15 --no-flat-rebuild --persistent-groups 4224 --ray-order coherent --workgroup-size 128 --shared-stack "$k" ;;
    # benchpers_SCENE: DDGI's full probe update at 32x32x32 probes x 256 rays, thread a ray
    # (ddgi_trace traces and shades) against the persistent trace (ddgi_trace finds the closest
    # hits with persistent threads, ddgi_shade shades them), timed in the same run; the ratio table
    # last. BENCH_ARGS: other bench ddgi options (e.g. "--probes 32,8,32 --rays 128").
    benchpers_*) scene=${step#benchpers_}; run "$step" $B bench ddgi --scene "$scene" --iterations 15 --persistent-trace ${BENCH_ARGS:---probes 32,32,32 --rays 256} --json "$R/$step.json" ;;
    # tracerb_SCENE-BUDGET: the TLAS partially re-braided at BUDGET primitives an instance (TRACE_ARGS as above).
    tracerb_*) IFS=- read -r scene budget <<< "${step#tracerb_}"; run "$step" $B bench trace --scene "$scene" --iterations 15 --no-flat-rebuild --rebraid "$budget" ${TRACE_ARGS:-} ;;
    tracecpu_*) scene=${step#tracecpu_}; run "$step" $B bench trace --scene "$scene" --iterations 15 --no-flat-rebuild --cpu-only ;;
    # tracegpurefit_SCENE: the CPU cost of the TLAS refit on the CPU and on the GPU (TlasRefit::Gpu),
    # then the whole bench with the GPU refit's GPU ms.
    tracegpurefit_*) scene=${step#tracegpurefit_}; run "$step" $B bench trace --scene "$scene" --iterations 15 --no-flat-rebuild --cpu-only --gpu-refit --json "$R/$step.json" ;;
    tracegpurefitgpu_*) scene=${step#tracegpurefitgpu_}; run "$step" $B bench trace --scene "$scene" --iterations 15 --no-flat-rebuild --gpu-refit --json "$R/$step.json" ;;
    # tracesg_SCENE: postponed triangle tests (subgroup ballots) at three shares, with and without
    # the dynamic fetch, in the best persistent kernel (4,224 workgroups of 128, coherent order),
    # against tests at once in the same run; tracesgt_SCENE: the same thread a ray.
    tracesg_*) scene=${step#tracesg_}; run "$step" $B bench trace --scene "$scene" --iterations 15 --no-flat-rebuild --persistent-groups 4224 --ray-order coherent --workgroup-size 128 --subgroup-postpone 0.2,0.35,0.5 --subgroup-fetch --json "$R/$step.json" ;;
    tracesgt_*) scene=${step#tracesgt_}; run "$step" $B bench trace --scene "$scene" --iterations 15 --no-flat-rebuild --ray-order coherent --workgroup-size 128 --subgroup-postpone 0.2,0.35,0.5 --json "$R/$step.json" ;;
    classify_*) scene=${step#classify_}; run "$step" $B bench classify --scene "$scene" ;;
    classifyfine_*) scene=${step#classifyfine_}; run "$step" $B bench classify --scene "$scene" --probes 32,16,32 ;;
    reference_*) scene=${step#reference_}; run "$step" $B render --scene "$scene" --mode pathtrace --spp 4096 --width 96 --height 96 --out "$R/$step" ;;
    # walk-CASCADES-X,Y,Z: the open world's tour at 1920x1080, adaptive budgets; CASCADES 0 is one
    # volume over the scene's GI bounds with X,Y,Z probes. WALK_ARGS: more bench walk options.
    walk-*) IFS=- read -r _ cascades grid <<< "$step"; run "$step" $B bench walk --cascades "$cascades" --probes "$grid" --cascade-probes "$grid" --out "$R/$step" ${WALK_ARGS:-} ;;
    # offset-SCENE-X,Y,Z: the still evaluation of SCENE placed at X,Y,Z (the reference is the
    # scene's at the origin: the cache key leaves the placement out).
    offset-*) IFS=- read -r _ scene at <<< "$step"; run "$step" $B eval --scene "$scene" --width 256 --height 256 --reference-spp 4096 --offset "$at" --out "$R/$step" --cache $CACHE ;;
    # view-D: the open world seen from the tour at D metres (positions in tools' VIEWS), one
    # volume of 32x8x32 probes against 4 cascades of 16x8x16 (the same rays per frame).
    # VIEW_CASCADES: other cascade options (e.g. "--cascades 8 --cascade-probes 16,4,16 --cascade-blend 1").
    view-*) d=${step#view-}; read -r eye target <<< "${VIEWS[$d]}"; run "$step" $B eval --scene open_world --width 256 --height 256 --reference-spp 4096 --probes 32,8,32 --cascade-spacing 1.5 ${VIEW_CASCADES:---cascades 4 --cascade-probes 16,8,16} --camera-position "$eye" --camera-target "$target" --fov 70 --out "$R/$step" --cache $CACHE ;;
    # walkseries-FROM-SPEED-FRAMES: eval --time-series --walk on the open world's tour from FROM
    # metres at SPEED m/s for FRAMES frames, 256x256, every frame against a 256-spp reference of
    # its view, under the pale sky; one volume of 32x8x32 (fixed and adaptive) and 8 cascades of
    # 16x4x16 (SERIES_CASCADES: other cascade options).
    walkseries-*) IFS=- read -r _ from speed frames <<< "$step"; run "$step" $B eval --scene open_world --time-series --walk --walk-from "$from" --walk-speed "$speed" --frames "$frames" --settle-frames 120 --width 256 --height 256 --reference-spp 256 --probes 32,8,32 --cascade-spacing 1.5 ${SERIES_CASCADES:---cascades 8 --cascade-probes 16,4,16 --cascade-blend 1} --sky 0.35,0.45,0.6 --out "$R/$step" --cache $CACHE ;;
    # peer_SCENE: the peer benchmark against sgl-3d (docs/evaluation.md, "Peer benchmark"), its
    # timed rows interleaved frame by frame; the binary P (default .peer/peer, built from peer/ with
    # `cargo build --release --ignore-rust-version --manifest-path peer/Cargo.toml`); cornell at
    # 256x256, other scenes (cathedral, level) at 1280x720, 128 rays a probe. PEER_ARGS: more options.
    peer_*) scene=${step#peer_}; size="--width 1280 --height 720"; [ "$scene" = cornell ] && size="--width 256 --height 256"; run "$step" ${P:-.peer/peer} --scene "$scene" $size --rays 128 --out "$R/$step" --json "$R/$step.json" --cache $CACHE ${PEER_ARGS:-} ;;
    esac
done
pack && rm -rf "$R"
