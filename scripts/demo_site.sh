#!/usr/bin/env bash
# make demo-site: one sky node and three HMD nodes of the sample site over a real MQTT broker
# (docs/site.md). Starts mosquitto on a free loopback port, films three camera paths, runs the
# HMD nodes headless and the sky node through the simulated clear day, and writes into OUT
# (default build/demo/site): each node's recording and frame log, a contact sheet of the three
# side by side at the same sky times, and the sky node's /site JSON taken while they ran.
#
#   scripts/demo_site.sh BUILD_DIR [OUT]
set -euo pipefail
build=${1:?usage: scripts/demo_site.sh BUILD_DIR [OUT]}
repo=$(cd "$(dirname "$0")/.." && pwd)
out=${2:-$repo/build/demo/site}
bin=$build/bin
mkdir -p "$out"
out=$(cd "$out" && pwd)
pids=()
stop_all() { for pid in "${pids[@]}"; do kill "$pid" 2>/dev/null || true; done; wait 2>/dev/null || true; }
trap stop_all EXIT

free_port() { python3 -c 'import socket; s = socket.socket(); s.bind(("127.0.0.1", 0)); print(s.getsockname()[1])'; }
wait_for_port() {  # PORT SECONDS
  for _ in $(seq $(($2 * 10))); do
    python3 -c "import socket, sys; socket.create_connection(('127.0.0.1', $1), 0.2)" 2>/dev/null && return 0
    sleep 0.1
  done
  echo "demo-site: nothing listens on 127.0.0.1:$1 after $2 s" >&2
  return 1
}

# The bake and camera recording the configs name (build/demo, as make demo leaves them).
if [ ! -f "$repo/build/demo/bake/manifest.json" ]; then
  "$bin/skylit-bake" "$repo/config/sample_site.yaml" -o "$repo/build/demo/bake" --force
fi
echo "demo-site: three HMD camera paths"
for n in 1 2 3; do
  azimuth=$(( -150 + 60 * n ))
  "$bin/skylit-camera-sim" --calib "$repo/config/hmd_camera.yaml" -o "$out/camera-$n" \
    --frames 120 --sweep 50 --start-azimuth "$azimuth" -q
done

broker_port=$(free_port)
cat > "$out/mosquitto.conf" <<CONF
listener $broker_port 127.0.0.1
allow_anonymous true
persistence false
CONF
/usr/sbin/mosquitto -c "$out/mosquitto.conf" > "$out/mosquitto.log" 2>&1 &
pids+=($!)
wait_for_port "$broker_port" 10
echo "demo-site: mosquitto on 127.0.0.1:$broker_port"

# Each HMD node: config/site_hmd.yaml with its own name and camera path (absolute paths, since
# the copy lives in OUT).
hmd_pids=()
for n in 1 2 3; do
  sed -e "s|^root: \.\.|root: $repo|" -e "s|^site: |site: $repo/config/|" -e "s|^bake: \.\./|bake: $repo/|" \
      -e "s|  calibration: |  calibration: $repo/config/|" \
      -e "s|    path: \.\./build/demo/camera|    path: $out/camera-$n|" \
      -e "s|  csv: \.\./build/demo/camera/poses.csv|  csv: $out/camera-$n/poses.csv|" \
      -e "s|    node: hmd-1|    node: hmd-$n|" "$repo/config/site_hmd.yaml" > "$out/hmd-$n.yaml"
  "$bin/skylit-live" "$out/hmd-$n.yaml" --headless --broker "127.0.0.1:$broker_port" \
    --record "$out/hmd-$n.mp4" -q > "$out/hmd-$n.log" 2>&1 &
  hmd_pids+=($!)
  pids+=($!)
done

status_port=$(free_port)
echo "demo-site: the sky node (status on http://127.0.0.1:$status_port/site) and three HMD nodes (about 45 s)"
"$bin/skylit-sky-node" "$repo/config/site_sky.yaml" --broker "127.0.0.1:$broker_port" \
  --status "127.0.0.1:$status_port" -q > "$out/sky-node.log" 2>&1 &
sky_pid=$!
pids+=($sky_pid)
wait_for_port "$status_port" 30

# /site while every HMD node runs: the last answer in which all three are heard and running.
while kill -0 "${hmd_pids[@]}" 2>/dev/null && kill -0 "$sky_pid" 2>/dev/null; do
  python3 - "$status_port" "$out/site.json" <<'PY' || true
import json, sys, urllib.request
text = urllib.request.urlopen(f"http://127.0.0.1:{sys.argv[1]}/site", timeout=2).read()
site = json.loads(text)
if len(site["nodes"]) == 3 and all(n["state"] == "running" for n in site["nodes"]):
    open(sys.argv[2], "wb").write(text)
PY
  sleep 1
done
for pid in "${hmd_pids[@]}"; do wait "$pid"; done
kill "$sky_pid" 2>/dev/null || true
wait "$sky_pid" 2>/dev/null || true

"$bin/skylit-contact-sheet" "$out/hmd-1.mp4" "$out/hmd-2.mp4" "$out/hmd-3.mp4" -o "$out/contact_sheet.png" \
  --times 4 --utc-offset 9
[ -f "$out/site.json" ] || { echo "demo-site: the sky node never heard all three HMD nodes running" >&2; exit 1; }
python3 - "$out/site.json" <<'PY'
import json, sys
site = json.load(open(sys.argv[1]))
for n in site["nodes"]:
    print(f"demo-site: {n['node']}: {n['state']}, {n['frame_rate']:.1f} frames/s, sky {n['sky_sequence']}, "
          f"flags {', '.join(n['flags']) or 'none'}, heard {n['seconds_since_heard']:.1f} s ago")
PY
echo "demo-site: recordings $out/hmd-{1,2,3}.mp4, contact sheet $out/contact_sheet.png, /site in $out/site.json"
