#!/bin/bash
# Scale measurement of `texdefrag batch` (docs/batch.md, "Scale"): a synthetic city of N small
# tiles (`texdefrag synth --count`), defragmented on a local Dask cluster (one thread per worker,
# nice -n 10) with each worker count given, each phase stopped after BUDGET seconds (Ctrl-C: the
# journal keeps what finished). Prints per-tile figures from the journal (partial runs included).
#   tools/batch/scale.sh BUILD_DIR WORKDIR [N=200] [CONFIG=configs/best.json] [BUDGET_S=3600] [WORKERS="1 2"]
set -uo pipefail
build=$(realpath "$1"); work=$2; n=${3:-200}
src=$(cd "$(dirname "$0")/../.." && pwd)
config=$(realpath "${4:-$src/configs/best.json}"); budget=${5:-3600}; counts=${6:-1 2}
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
cleanup() { for p in "${pids[@]}"; do kill "$p" 2>/dev/null; done; wait 2>/dev/null; }
trap cleanup EXIT
nice -n 10 dask-scheduler --host 127.0.0.1 --port "$port" --dashboard-address :0 >"$work/scheduler.log" 2>&1 &
pids+=($!)
for workers in $counts; do
  wpids=()
  for ((i = 0; i < workers; i++)); do
    nice -n 10 dask-worker "$addr" --nthreads 1 --no-nanny --memory-limit 0 --dashboard-address :0 \
        --local-directory "$work/w$i" >"$work/worker$workers.$i.log" 2>&1 &
    wpids+=($!); pids+=($!)
  done
  out=$work/out$workers
  timeout -s INT "$budget" nice -n 10 "$exe" batch "$work/city" -o "$out" --config "$config" \
      --scheduler "$addr" --connect-timeout 60 --quiet
  echo "batch with $workers worker(s): exit $?"
  for p in "${wpids[@]}"; do kill "$p"; done
  sleep 2
done
for workers in $counts; do
  /usr/bin/python3 - "$work/out$workers" "$workers" <<'PY'
import json, os, sqlite3, statistics, sys
out, workers = sys.argv[1], int(sys.argv[2])
db = sqlite3.connect(os.path.join(out, ".texdefrag-batch", "journal.sqlite"))
rows = db.execute("SELECT started_at, finished_at, wall_s, figures, files, outputs FROM tasks WHERE status='finished'").fetchall()
start = db.execute("SELECT min(started_at) FROM batches").fetchone()[0]
end = max(r[1] for r in rows)
fig = [json.loads(r[3]) for r in rows]
inb = [sum(f[1] for f in json.loads(r[4])) for r in rows]
outb = [sum(os.path.getsize(os.path.join(out, o)) for o in json.loads(r[5])) for r in rows]
def med(v): return statistics.median(v)
span = end - start
print(f"{workers} worker(s): {len(rows)} tiles finished in {span:.0f} s: {len(rows) / span * 3600:.0f} tiles/h, "
      f"{span / len(rows):.1f} s/tile")
print(f"  per tile: faces median {med([f['faces'] for f in fig]):.0f}; wall median {med([r[2] for r in rows]):.1f} s; "
      f"CPU (user+sys) median {med([f['cpu_s'] for f in fig]):.2f} s mean {statistics.fmean([f['cpu_s'] for f in fig]):.2f} s "
      f"max {max(f['cpu_s'] for f in fig):.2f} s; run report time median {med([f['time_s'] for f in fig]):.2f} s; "
      f"peak RSS median {med([f['max_rss_kb'] for f in fig]) / 1024:.0f} MiB max {max(f['max_rss_kb'] for f in fig) / 1024:.0f} MiB")
print(f"  bytes per tile: input median {med(inb) / 1e6:.2f} MB mean {statistics.fmean(inb) / 1e6:.2f} MB; "
      f"output median {med(outb) / 1e6:.2f} MB mean {statistics.fmean(outb) / 1e6:.2f} MB")
PY
done
