#!/usr/bin/env bash
# A local multi-node Ray cluster on this machine, loopback only:
#   cluster/local_cluster.sh start [WORKERS]   head (0 CPUs; dashboard and Jobs API on 127.0.0.1:8265) + WORKERS
#                                              worker nodes with 1 CPU each (default 2); prints the Jobs API URL
#   cluster/local_cluster.sh add N             one more worker node (1 CPU), agent port = base + N (N > WORKERS)
#   cluster/local_cluster.sh stop              stops the nodes that `start` started (those of its GCS port), not
#                                              any other Ray of this machine
# Every node advertises 127.0.0.1 (cluster/ray_start_loopback.py keeps Ray from replacing it with the machine's
# address), so no Ray server listens beyond loopback. Token auth stays on; the token file is made 0600.
# Agent ports start at 52300, not at Ray's default 52365: every embedded Ray on the machine (`onepiece run`) takes
# 52365 for its agent (ray.init has no switch for it), and a head started beside one could not bind it, so the Jobs
# API answered "No available agent to submit job" for the cluster's whole life.
set -euo pipefail
here=$(cd "$(dirname "$0")/.." && pwd)
venv=${ONEPIECE_VENV:-$here/.venv}
ray_bin=$venv/bin/ray
port=${ONEPIECE_RAY_PORT:-6390}
dashboard_port=${ONEPIECE_DASHBOARD_PORT:-8265}
agent_port=${ONEPIECE_AGENT_PORT:-52300}
export RAY_USAGE_STATS_ENABLED=0 RAY_AUTH_MODE=token PATH="$venv/bin:$PATH"
# The GCS checks each node every second (Ray's default: 3 s): a dead node is found in 5 s instead of 15, a busy one
# that answers late still has 5 x 10 s of timeouts (the embedded Ray does the same: runtime/ray_env.py)
export RAY_health_check_period_ms=1000
ray_start() { "$venv/bin/python" "$here/cluster/ray_start_loopback.py" "$@"; }

start() {
  local workers=${1:-2}
  ray_start --head --node-ip-address=127.0.0.1 --port="$port" --num-cpus=0 \
    --dashboard-host=127.0.0.1 --dashboard-port="$dashboard_port" --dashboard-agent-listen-port="$agent_port" \
    --disable-usage-stats >&2
  for i in $(seq "$workers"); do  # nodes share one address: each agent needs a port of its own
    ray_start --address="127.0.0.1:$port" --node-ip-address=127.0.0.1 --num-cpus=1 \
      --dashboard-agent-listen-port=$((agent_port + i)) --disable-usage-stats >&2
  done
  [ -f "$HOME/.ray/auth_token" ] && chmod 600 "$HOME/.ray/auth_token"
  echo "http://127.0.0.1:$dashboard_port"
}

add_node() {  # one more worker node; N picks its agent port
  ray_start --address="127.0.0.1:$port" --node-ip-address=127.0.0.1 --num-cpus=1 \
    --dashboard-agent-listen-port=$((agent_port + $1)) --disable-usage-stats >&2
}

case "${1:-}" in
  start) shift; start "$@" ;;
  add)   shift; add_node "${1:?usage: $0 add N}" ;;
  stop)  "$venv/bin/python" - "$port" <<'PY' >&2 ;;
import sys, psutil
port = sys.argv[1]
mine = [p for p in psutil.process_iter(["cmdline"]) if p.info["cmdline"] and any(
    f"127.0.0.1:{port}" in arg or arg == f"--gcs_server_port={port}" for arg in p.info["cmdline"])]
family = {q for p in mine for q in [p, *p.children(recursive=True)] if q.is_running()}
for proc in family:
    try:
        proc.kill()
    except psutil.NoSuchProcess:
        pass
psutil.wait_procs(list(family), timeout=10)
print(f"stopped {len(family)} processes of the cluster on port {port}")
PY
  *)     echo "usage: $0 start [WORKERS] | add N | stop" >&2; exit 2 ;;
esac
