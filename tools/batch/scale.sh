#!/bin/bash
# Scale measurement of `texdefrag batch` (docs/batch.md, "Scale"): a synthetic city of N small
# tiles (`texdefrag synth --count`), defragmented on a local Dask cluster with 1 then 2 workers
# (one thread each, nice -n 10). Prints the per-tile figures the 10,000-tile estimate uses.
#   tools/batch/scale.sh BUILD_DIR WORKDIR [N=200] [CONFIG=configs/best.json]
set -euo pipefail
build=$(realpath "$1"); work=$2; n=${3:-200}
src=$(cd "$(dirname "$0")/../.." && pwd)
config=$(realpath "${4:-$src/configs/best.json}")
exe=$build/bin/texdefrag
mkdir -p "$work"; work=$(realpath "$work")

if [ ! -f "$work/city/manifest.json" ]; then
  /usr/bin/time -f "synth: %e s wall" nice -n 10 "$exe" synth --count "$n" --seed 2026 \
      --min-faces 2000 --max-faces 8000 -o "$work/city.tmp" >/dev/null
  find "$work/city.tmp" -name '*.truth.json' -delete
  mv "$work/city.tmp" "$work/city"
fi
du -sb "$work/city" | awk '{printf "input: %.1f MB\n", $1/1e6}'

port=$(/usr/bin/python3 -c 'import socket; s=socket.socket(); s.bind(("127.0.0.1",0)); print(s.getsockname()[1])')
addr=tcp://127.0.0.1:$port
pids=()
cleanup() { for p in "${pids[@]}"; do kill "$p" 2>/dev/null || true; done; wait 2>/dev/null || true; }
trap cleanup EXIT
nice -n 10 dask-scheduler --host 127.0.0.1 --port "$port" --dashboard-address :0 >"$work/scheduler.log" 2>&1 &
pids+=($!)
for workers in 1 2; do
  wpids=()
  for ((i = 0; i < workers; i++)); do
    nice -n 10 dask-worker "$addr" --nthreads 1 --no-nanny --memory-limit 0 --dashboard-address :0 \
        --local-directory "$work/w$i" >"$work/worker$workers.$i.log" 2>&1 &
    wpids+=($!); pids+=($!)
  done
  out=$work/out$workers
  rm -rf "$out"
  start=$(date +%s.%N)
  nice -n 10 "$exe" batch "$work/city" -o "$out" --config "$config" --scheduler "$addr" \
      --connect-timeout 60 --quiet || echo "batch with $workers worker(s): exit $?"
  end=$(date +%s.%N)
  /usr/bin/python3 - "$out" "$workers" "$start" "$end" <<'EOF'
import json, sys
out, workers, start, end = sys.argv[1], int(sys.argv[2]), float(sys.argv[3]), float(sys.argv[4])
s = json.load(open(f"{out}/.texdefrag-batch/summary.json"))
p = s["per_task"]
print(f"{workers} worker(s): {s['tasks']['finished']}/{s['tasks']['total']} finished, wall {end - start:.1f} s "
      f"({(end - start) / s['tasks']['total']:.2f} s/tile, {s['tasks']['total'] / (end - start) * 3600:.0f} tiles/h)")
for k in ("faces", "wall_s", "time_s", "peak_rss_mb", "input_bytes", "output_bytes"):
    if p.get(k):
        print(f"  {k}: median {p[k]['median']:.4g} mean {p[k]['mean']:.4g} max {p[k]['max']:.4g} sum {p[k]['sum']:.4g}")
EOF
  du -sb "$out" | awk '{printf "  output folder: %.1f MB\n", $1/1e6}'
  for p in "${wpids[@]}"; do kill "$p"; done
  sleep 2
done
