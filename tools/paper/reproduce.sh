#!/usr/bin/env bash
# The reproduction of Liu et al. 2024's Figures 16-20 on buildings cut from real tiles (docs/paper.md).
#
#   tools/paper/reproduce.sh SET RESULTS [options]
#     --per-tile N        largest buildings kept per development tile (default 5)
#     --synth-count N     hard synthetic buildings (default 2; --synth-faces MIN:MAX, default 8000:10000)
#     --tile OBJ          cut this tile instead of the six development tiles (repeatable)
#     --min-faces N       smallest building kept by `texdefrag buildings` (default 200)
#     --texture           also measure texture fidelity (PSNR; off by default: not in Figures 16-20,
#                         and it is 80% of an evaluation's time)
#     --samples N         texture-fidelity samples per evaluation (default 200000)
#     --no-mmethod        do not run the M-method's own program (mmethod_orig)
#     --configs "A B"     configurations to bench (default: paper best mmethod and the three ablations)
#     --exe TEXDEFRAG     the executable (default build/bin/texdefrag)
#
# Steps (each resumes: delete SET or RESULTS to redo):
#   1. SET/manifest.json: tools/paper/make_buildings.py (skipped when SET/manifest.json exists);
#   2. SET/mmethod/<model>/: the M-method's program, tools/paper/run_mmethod.py (when installed);
#   3. RESULTS/: texdefrag bench -j1 of the configurations (+ external mmethod_orig);
#   4. RESULTS/figures (paper, mmethod_orig, mmethod, best) and RESULTS/figures_ablations (paper and
#      each ablation), eval/plots/plots.py; RESULTS/paper_numbers*.md, tools/paper/paper_numbers.py;
#      RESULTS/causes_*.md, tools/paper/causes.py; RESULTS/building_set.png, tools/paper/render_set.py.
# Heavy steps run under `nice -n 10`. SET and RESULTS must be outside the input folders.
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
root=$(cd "$here/../.." && pwd)
usage() { sed -n '2,16p' "$0" | sed 's/^# \{0,1\}//' >&2; exit 2; }
[ $# -ge 2 ] || usage
set_dir=$1 results=$2
shift 2
per_tile=5 synth_count=2 synth_faces=8000:10000 min_faces=200 samples=200000 mmethod=1 texture=--no-texture
exe=$root/build/bin/texdefrag
configs="paper best mmethod ablations/angle_growing ablations/arap ablations/tetris"
tiles=()
while [ $# -gt 0 ]; do
  case $1 in
    --per-tile) per_tile=$2; shift 2 ;;
    --synth-count) synth_count=$2; shift 2 ;;
    --synth-faces) synth_faces=$2; shift 2 ;;
    --tile) tiles+=(--tile "$2"); shift 2 ;;
    --min-faces) min_faces=$2; shift 2 ;;
    --samples) samples=$2; shift 2 ;;
    --no-mmethod) mmethod=0; shift ;;
    --texture) texture=; shift ;;
    --configs) configs=$2; shift 2 ;;
    --exe) exe=$2; shift 2 ;;
    *) echo "reproduce.sh: unknown option '$1'" >&2; usage ;;
  esac
done
[ -x "$exe" ] || { echo "reproduce.sh: no texdefrag executable at $exe (build it or give --exe)" >&2; exit 2; }
py=${TEXDEFRAG_PYTHON:-/usr/bin/python3}
[ -x "$py" ] || py=python3

if [ ! -f "$set_dir/manifest.json" ]; then
  nice -n 10 "$py" "$here/make_buildings.py" -o "$set_dir" --per-tile "$per_tile" --min-faces "$min_faces" \
    --synth-count "$synth_count" --synth-faces "$synth_faces" --exe "$exe" ${tiles[@]+"${tiles[@]}"}
fi

external=()
mm_tool=$root/../shared/tools/mmethod/run.sh
if [ "$mmethod" = 1 ]; then
  if [ -x "$mm_tool" ]; then
    "$py" "$here/run_mmethod.py" --set "$set_dir" --tool "$mm_tool" ||
      echo "reproduce.sh: the M-method's program has no output for some models (bench records them as missing)" >&2
    external=(--external "mmethod_orig=$set_dir/mmethod")
  else
    echo "reproduce.sh: no M-method program at $mm_tool: mmethod_orig left out" >&2
  fi
fi

cfg_files=()
labels=()
for c in $configs; do
  f=$c
  [ -f "$f" ] || f=$root/configs/$c.json
  [ -f "$f" ] || { echo "reproduce.sh: no configuration '$c'" >&2; exit 2; }
  cfg_files+=("$f")
  labels+=("$(basename "$f" .json)")
done
rc=0
nice -n 10 "$exe" bench --data "$set_dir/manifest.json" --configs "${cfg_files[@]}" ${external[@]+"${external[@]}"} \
  --out "$results" -j1 --samples "$samples" ${texture:+"$texture"} --no-plots || rc=$?
[ "$rc" -le 1 ] || exit "$rc"   # 1 = some pair failed (recorded); 2 = bad arguments

# Main figures: paper, the original M-method program, our M-method, best (those present);
# ablation figures: paper and every other configuration.
main=() abl=() rest=()
for l in "${labels[@]}"; do
  case $l in
    paper) main=(paper ${main[@]+"${main[@]}"}); abl=(paper ${abl[@]+"${abl[@]}"}) ;;
    best|mmethod) rest+=("$l") ;;
    *) abl+=("$l") ;;
  esac
done
[ ${#external[@]} -eq 0 ] || main+=(mmethod_orig)
main+=(${rest[@]+"${rest[@]}"})
plots() {  # plots.py exit 3 = matplotlib missing: tables written, no figure (not a failure here)
  local r=0
  "$py" "$root/eval/plots/plots.py" --results "$results" "$@" || r=$?
  if [ "$r" = 3 ]; then echo "reproduce.sh: matplotlib missing: no figures" >&2; elif [ "$r" != 0 ]; then rc=$r; fi
}
[ ${#main[@]} -eq 0 ] || plots --configs "${main[@]}" --figures "$results/figures" --summary "$results/summary.md"
[ ${#abl[@]} -le 1 ] || plots --configs "${abl[@]}" --figures "$results/figures_ablations" \
  --summary "$results/summary_ablations.md"
# The paper's statistics: all models, real, synthetic, and real without the rural tile's pieces
# (t078_*: terrain the semantic detector classes as one building, docs/paper.md).
numbers() {  # numbers SUFFIX ARGS...: paper_numbers_SUFFIX.md, paper_numbers_ablations_SUFFIX.md
  local sfx=$1
  shift
  [ ${#main[@]} -eq 0 ] || "$py" "$here/paper_numbers.py" --results "$results" --configs "${main[@]}" "$@" \
    --out "$results/paper_numbers_$sfx.md" || echo "reproduce.sh: no paper numbers ($sfx)" >&2
  [ ${#abl[@]} -le 1 ] || "$py" "$here/paper_numbers.py" --results "$results" --configs "${abl[@]}" "$@" \
    --out "$results/paper_numbers_ablations_$sfx.md" || echo "reproduce.sh: no ablation numbers ($sfx)" >&2
}
for kind in all real synthetic; do numbers "$kind" --kind "$kind"; done
numbers urban --kind real --exclude t078_
for kind in real synthetic; do
  "$py" "$here/causes.py" --results "$results" --kind "$kind" --out "$results/causes_$kind.md" ||
    echo "reproduce.sh: no causes table ($kind)" >&2
done
"$py" "$here/render_set.py" "$set_dir" "$results/building_set.png" ||
  echo "reproduce.sh: no picture of the building set" >&2
echo "reproduce.sh: results in $results (summary.md, figures/, figures_ablations/, paper_numbers_*.md)"
exit "$rc"
