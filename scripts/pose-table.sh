#!/usr/bin/env bash
# Runs the fits behind the README's pose-fit tables with the fit_pose example and prints each
# row's summary (median / p90 / worst per-vertex error, failures, time per fit).
#
#   scripts/pose-table.sh [--table rows|wider|table2] [--only REGEX] [--jobs N] [--out DIR] [--list]
#
#   --table   rows:   the table of *Robustness and real bodies* (default; about 2,400 fits)
#             wider:  the wider check on unseen seeds (1,610 fits)
#             table2: paper Table 2 on the body and the figure (`--ablation 30`)
#             user-data: the README's *Your own masks and cameras* (330 fits): hard 640x480
#                     masks of irregular rigs fitted from the masks and cameras alone
#                     (`--as-user-data`), the body turned, in turned and moved worlds, and at
#                     other working resolutions (`--fit-height`; 0, the masks as they are,
#                     takes about 20 s a fit)
#   --only    run only the rows whose label matches this extended regular expression (awk's)
#   --jobs    rows run at once, each one process on one thread, its seeds one after another
#             (default: the number of cores)
#   --out     where each row's full output goes, one file per row (default target/pose-table)
#   --list    print the rows' labels and arguments and exit
#
# Rows with CesiumMan or RiggedFigure need DIFFSIL_ASSETS (the folder holding those .glb files);
# without it they are skipped, and said so. Each row runs on one thread (RAYON_NUM_THREADS=1), so
# that rows running side by side do not share cores and the times per fit compare. On this project's
# 2-core VM, --jobs 2, the wider check took about half an hour; the rows, by their times per fit,
# about an hour.
set -euo pipefail
cd "$(dirname "$0")/.."

table=rows only='' out=target/pose-table list=0
jobs=$(nproc 2>/dev/null || echo 2)
while [ $# -gt 0 ]; do
  case "$1" in --table|--only|--jobs|--out) [ $# -ge 2 ] || { echo "$1 wants a value" >&2; exit 2; } ;; esac
  case "$1" in
    --table) table="$2"; shift 2 ;;
    --only) only="$2"; shift 2 ;;
    --jobs) jobs="$2"; shift 2 ;;
    --out) out="$2"; shift 2 ;;
    --list) list=1; shift ;;
    -h|--help) awk 'NR > 1 && /^#/ { sub(/^# ?/, ""); print; next } NR > 1 { exit }' "$0"; exit 0 ;;
    *) echo "unknown argument: $1 (see --help)" >&2; exit 2 ;;
  esac
done
case "$jobs" in ''|*[!0-9]*|0) echo "--jobs wants a positive whole number, not '$jobs'" >&2; exit 2 ;; esac

# One row per line: label|arguments of fit_pose. $A stands for DIFFSIL_ASSETS.
rows() {
  case "$table" in
  rows) cat <<'EOF'
body-1-30|--seeds 1-30
body-31-60|--seeds 31-60
body-91-120|--seeds 91-120
body-151-180|--seeds 151-180
body-181-210|--seeds 181-210
body-211-240|--seeds 211-240
shape-1-10|--shape --seeds 1-10
body-eroded-1-10|--seeds 1-10 --mask-noise erode
body-eroded-11-20|--seeds 11-20 --mask-noise erode
body-eroded-21-40|--seeds 21-40 --mask-noise erode
body-eroded-41-60|--seeds 41-60 --mask-noise erode
shape-1-40|--shape --seeds 1-40
shape-eroded-1-40|--shape --seeds 1-40 --mask-noise erode
walk-12|--model $A/CesiumMan.glb --motion 0
walk-48|--model $A/CesiumMan.glb --motion 0 --frames 100
figure-31-80|--figure --seeds 31-80
figure-81-130|--figure --seeds 81-130
figure-131-180|--figure --seeds 131-180
figure-181-230|--figure --seeds 181-230
figure-231-330|--figure --seeds 231-330
figure-331-380|--figure --seeds 331-380
figure-381-480|--figure --seeds 381-480
figure-481-560|--figure --seeds 481-560
figure-31-50|--figure --seeds 31-50
figure-dilated-31-50|--figure --seeds 31-50 --mask-noise dilate
figure-flipped-31-50|--figure --seeds 31-50 --mask-noise flip
figure-eroded-31-50|--figure --seeds 31-50 --mask-noise erode
figure-eroded-51-70|--figure --seeds 51-70 --mask-noise erode
figure-eroded-71-110|--figure --seeds 71-110 --mask-noise erode
figure-eroded-111-150|--figure --seeds 111-150 --mask-noise erode
figure-eroded-151-230|--figure --seeds 151-230 --mask-noise erode
figure-151-230|--figure --seeds 151-230
rigged-1-20|--model $A/RiggedFigure.glb --seeds 1-20
rigged-21-40|--model $A/RiggedFigure.glb --seeds 21-40
rigged-41-60|--model $A/RiggedFigure.glb --seeds 41-60
cesium-1-300|--model $A/CesiumMan.glb --seeds 1-300
cesium-head-turns-1-300|--model $A/CesiumMan.glb --seeds 1-300 --head-turns 0.85
body-irregular-1-120|--views irregular --seeds 1-120
figure-irregular-31-230|--figure --views irregular --seeds 31-230
walk-irregular-rig-1|--model $A/CesiumMan.glb --motion 0 --views irregular --seed 1
walk-irregular-rig-2|--model $A/CesiumMan.glb --motion 0 --views irregular --seed 2
walk-irregular-rig-3|--model $A/CesiumMan.glb --motion 0 --views irregular --seed 3
walk-irregular-rig-4|--model $A/CesiumMan.glb --motion 0 --views irregular --seed 4
walk-irregular-rig-5|--model $A/CesiumMan.glb --motion 0 --views irregular --seed 5
walk-irregular-rig-6|--model $A/CesiumMan.glb --motion 0 --views irregular --seed 6
cesium-irregular-1-100|--model $A/CesiumMan.glb --views irregular --seeds 1-100
EOF
  ;;
  wider) cat <<'EOF'
body-241-390|--seeds 241-390
body-391-540|--seeds 391-540
shape-11-100|--shape --seeds 11-100
figure-561-810|--figure --seeds 561-810
figure-811-1060|--figure --seeds 811-1060
rigged-61-260|--model $A/RiggedFigure.glb --seeds 61-260
figure-flipped-71-270|--figure --seeds 71-270 --mask-noise flip
figure-dilated-51-250|--figure --seeds 51-250 --mask-noise dilate
body-flipped-1-60|--seeds 1-60 --mask-noise flip
body-dilated-1-60|--seeds 1-60 --mask-noise dilate
EOF
  ;;
  table2) cat <<'EOF'
table2-body|--ablation 30
table2-figure|--figure --ablation 30
EOF
  ;;
  user-data)
    # The masks as a camera and a segmentation give them: 640x480, hard, irregular rigs.
    u='--views irregular --resolution 640x480 --threshold 0.5 --as-user-data'
    for turn in 0 45 90 135 180 225 270 315; do
      echo "facing-auto-turned-$turn|--seeds 1-6 $u --turn $turn"
      echo "facing-front-turned-$turn|--seeds 1-6 $u --turn $turn --facing 0"
    done
    cat <<EOF
up-z|--seeds 1-6 $u --world-up +z
up-minus-z|--seeds 1-6 $u --world-up -z
up-tilted-40|--seeds 1-6 $u --world-up 0,0.766,0.643
up-z-kept-y|--seeds 1-6 $u --world-up +z --up +y
where-origin|--seeds 1-30 $u
where-origin-unplaced|--seeds 1-30 $u --no-placement
where-2.9m|--seeds 1-30 $u --world-offset 2.5,0,-1.5
where-2.9m-unplaced|--seeds 1-30 $u --world-offset 2.5,0,-1.5 --no-placement
fit-height-0|--seeds 1-30 $u --fit-height 0
fit-height-48|--seeds 1-30 $u --fit-height 48
fit-height-96|--seeds 1-30 $u --fit-height 96
EOF
  ;;
  *) echo "unknown --table '$table' (rows, wider, table2 or user-data)" >&2; exit 2 ;;
  esac
}

selected=$(rows | awk -F'|' -v re="$only" '$1 ~ re')
if [ -z "$selected" ]; then
  echo "no row of --table $table matches --only '$only' (--list shows them)" >&2
  exit 2
fi
if [ "$list" = 1 ]; then
  printf '%s\n' "$selected" | sed 's/|/   /'
  exit 0
fi

# Rows that need the asset folder are skipped without it.
if [ -z "${DIFFSIL_ASSETS:-}" ]; then
  skipped=$(printf '%s\n' "$selected" | grep -F '$A/' | cut -d'|' -f1 | tr '\n' ' ' || true)
  [ -n "$skipped" ] && echo "DIFFSIL_ASSETS is not set: skipping $skipped" >&2
  selected=$(printf '%s\n' "$selected" | grep -vF '$A/' || true)
  [ -z "$selected" ] && { echo "nothing left to run" >&2; exit 2; }
fi

echo "building the fit_pose example (release)" >&2
exe=$(cargo build --release --example fit_pose --message-format=json-render-diagnostics \
  | grep -o '"executable":"[^"]*fit_pose[^"]*"' | tail -n 1 | cut -d'"' -f4)
[ -x "$exe" ] || { echo "could not find the built fit_pose example" >&2; exit 1; }

mkdir -p "$out"
export RAYON_NUM_THREADS=1 exe out DIFFSIL_ASSETS="${DIFFSIL_ASSETS:-}"
echo "running $(printf '%s\n' "$selected" | wc -l) rows, $jobs at a time; full output in $out/" >&2
printf '%s\n' "$selected" | while IFS='|' read -r label args; do
  printf '%s\0%s\0' "$label" "$args"
done | xargs -0 -n 2 -P "$jobs" bash -c '
  label=$0; read -r -a argv <<< "$1"
  for i in "${!argv[@]}"; do argv[i]=${argv[i]//\$A/$DIFFSIL_ASSETS}; done  # after the split: spaces in the path survive
  if "$exe" "${argv[@]}" > "$out/$label.txt" 2>&1; then
    echo "done: $label" >&2
  else
    echo "FAILED: $label (exit $?; see $out/$label.txt)" >&2
    exit 255
  fi'

# The summaries, in the order of the rows.
printf '%s\n' "$selected" | while IFS='|' read -r label args; do
  echo "== $label: fit_pose $args"
  grep -E '^summary:|^\| ' "$out/$label.txt" || echo "(no summary: see $out/$label.txt)"
done
