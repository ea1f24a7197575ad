#!/usr/bin/python3
"""A day with faults (docs/live.md, "Faults"; scripts/soak.sh): skylit-live, skylit-sky-node and a
mosquitto broker on loopback, on the sample site's bake with a tiny HMD camera looping as fast as the
renderer takes it, while faults come on a schedule, one at a time:

  camera    the camera folder removed, then restored         flag camera_reconnecting
  sky_node  the sky node killed, then started again          flag sky_node_offline
  broker    the broker stopped, then started again           flag broker_unreachable
  disk      the recordings' disk filled, then freed          flag recording_failing
  garbage   a malformed camera frame and malformed skies     counted: camera.malformed, sky drops

Every second it samples the HMD node's resident memory, open files and threads (/proc) and its
/status (frames, frame time, flags, the heap in use). It writes OUT/samples.csv, OUT/soak.png (a
plot), OUT/soak.json (the verdicts) and prints them; exit 1 when a goal is missed:
  - memory and open files flat: their growth after the run settles (the median of the last tenth
    of the samples against the first tenth's) under 1 KiB and 0.01 descriptors per 10^4 frames.
    Memory is the heap the program holds (malloc's count, exact); the resident set, which also
    moves with what the allocator keeps and the kernel pages, is reported beside it;
  - every fault shown in /status while it lasts, and cleared within `clear_s` after it ends;
  - no camera frame lost that the renderer was free to take: frames read = composited + dropped
    while busy (+ 2 in flight; malformed frames are counted apart).

The recordings' disk is a small tmpfs mounted over OUT/rec when the soak may mount one (root);
otherwise the disk fault is left out and the report says so.
"""
import argparse
import json
import os
import signal
import socket
import subprocess
import sys
import time
import urllib.request

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def wait_for(condition, timeout, what):
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        value = condition()
        if value:
            return value
        time.sleep(0.05)
    raise RuntimeError(f"soak: {what} within {timeout} s")


def listening(port):
    with socket.socket() as s:
        return s.connect_ex(("127.0.0.1", port)) == 0


def status(port):
    try:
        with urllib.request.urlopen(f"http://127.0.0.1:{port}/status", timeout=2) as r:
            return json.load(r)
    except Exception:
        return None


def proc_sample(pid):
    fields = {}
    with open(f"/proc/{pid}/status") as f:
        for line in f:
            key, _, value = line.partition(":")
            fields[key] = value.strip()
    return {"rss_kib": int(fields["VmRSS"].split()[0]), "threads": int(fields["Threads"]),
            "fds": len(os.listdir(f"/proc/{pid}/fd"))}


def descendant(pid, name):
    """The first process below `pid` whose command is `name`, or None."""
    for task in os.listdir(f"/proc/{pid}/task"):
        try:
            with open(f"/proc/{pid}/task/{task}/children") as f:
                children = [int(c) for c in f.read().split()]
        except FileNotFoundError:
            continue
        for child in children:
            try:
                with open(f"/proc/{child}/comm") as f:
                    if f.read().strip() == name:
                        return child
            except FileNotFoundError:
                continue
            found = descendant(child, name)
            if found:
                return found
    return None


class Process:
    """A child process, its output in a log file; stopped (TERM, then KILL) at the end. With
    `target`, the child is a wrapper (a profiler) and `target` the program below it that is
    sampled and signalled; the wrapper is left to finish its own output."""

    def __init__(self, name, args, log_dir, target=None):
        self.name, self.args, self.target = name, args, target
        self.log = open(os.path.join(log_dir, name + ".log"), "ab")
        self.proc = None
        self.start()

    def start(self):
        self.proc = subprocess.Popen(self.args, stdout=self.log, stderr=subprocess.STDOUT)

    def pid(self):
        if self.target is None:
            return self.proc.pid
        return wait_for(lambda: descendant(self.proc.pid, self.target), 30, f"{self.target} under {self.args[0]}")

    def kill(self, sig=signal.SIGKILL):
        if self.proc and self.proc.poll() is None:
            if self.target is not None and sig != signal.SIGKILL:
                os.kill(self.pid(), sig)
                self.proc.wait(timeout=600)  # a profiler writes its results after the program ends
                return
            self.proc.send_signal(sig)
            try:
                self.proc.wait(timeout=10)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()

    def running(self):
        return self.proc is not None and self.proc.poll() is None


def write(path, text):
    with open(path, "w") as f:
        f.write(text)


def prepare(args, out):
    """The tiny HMD camera, its frames, the bake, and the three configs."""
    bin_dir = os.path.join(args.build, "bin")
    bake = args.bake or os.path.join(out, "bake")
    if not os.path.exists(os.path.join(bake, "manifest.json")):
        subprocess.run([os.path.join(bin_dir, "skylit-bake"), os.path.join(REPO, "config/sample_site.yaml"),
                        "-o", bake, "--force"], check=True, stdout=subprocess.DEVNULL)
    write(os.path.join(out, "hmd_tiny.yaml"),
          "image_width: 64\nimage_height: 48\nmodel: pinhole\nfx: 50.2\nfy: 50.2\ncx: 31.5\ncy: 23.5\n"
          "D: [0, 0, 0, 0, 0]\nR_site_from_camera: [1, 0, 0, 0, 1, 0, 0, 0, 1]\nt_site_from_camera: [0, 0, 0]\n")
    camera = os.path.join(out, "camera")
    if not os.path.exists(os.path.join(camera, "frames.csv")):
        subprocess.run([os.path.join(bin_dir, "skylit-camera-sim"), "--calib", os.path.join(out, "hmd_tiny.yaml"),
                        "-o", camera, "--frames", "8", "--sweep", "10", "--start-azimuth", "-120"],
                       check=True, stdout=subprocess.DEVNULL)
    return bake


def configs(args, out, bake, ports):
    site = os.path.join(REPO, "config/sample_site.yaml")
    sky_calib = os.path.join(REPO, "config/sky_camera.yaml")
    write(os.path.join(out, "sky.yaml"), f"""root: /
site: {site}
bake: {bake}
sky:
  calibration: {sky_calib}
  source:
    kind: sky-sim
    calibration: {sky_calib}
    sky: clear
    start: 2026-06-21T06:00:00+09:00
    every: 1min
    frames: 1000000
    latitude: 34.69
    longitude: 135.80
    realtime: 60
  rate: 0
  sun: auto
link:
  broker: 127.0.0.1:{ports['broker']}
  node: sky
status:
  listen: 127.0.0.1:{ports['sky']}
""")
    write(os.path.join(out, "hmd.yaml"), f"""root: /
site: {site}
bake: {bake}
sky:
  source:
    kind: mqtt
    broker: 127.0.0.1:{ports['broker']}
    node: hmd-1
  stale_after: 30
camera:
  calibration: {os.path.join(out, 'hmd_tiny.yaml')}
  source:
    kind: images
    path: {os.path.join(out, 'camera')}
    loop: true
    reconnect: {{initial: 0.1, max: 0.5, silence: 0.5}}
pose:
  kind: fixed
  position: [0, -18, 1.6]
  look_at: [0, -6, 0]
blend:
  device: auto
output:
  window: false
  record: {os.path.join(out, 'rec', 'frames')}
status:
  listen: 127.0.0.1:{ports['hmd']}
""")
    write(os.path.join(out, "mosquitto.conf"), f"listener {ports['broker']} 127.0.0.1\nallow_anonymous true\n"
                                                "persistence false\n")


def mount_tmpfs(path, megabytes):
    os.makedirs(path, exist_ok=True)
    result = subprocess.run(["mount", "-t", "tmpfs", "-o", f"size={megabytes}m", "tmpfs", path],
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    return result.returncode == 0, result.stderr.strip()


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--frames", type=float, default=1e6, help="composited frames to run (default 10^6)")
    parser.add_argument("--max-seconds", type=float, default=4 * 3600, help="stop after this long in any case")
    parser.add_argument("--fault-every", type=float, default=60, help="seconds between faults")
    parser.add_argument("--fault-for", type=float, default=8, help="seconds each fault lasts")
    parser.add_argument("--clear-s", type=float, default=20, help="seconds a fault's flag may outlast it")
    parser.add_argument("--settle-frames", type=float, default=20000, help="frames before memory is judged")
    parser.add_argument("--no-memory-goal", action="store_true",
                        help="report the memory and descriptor slopes without judging them (a run too short to tell)")
    parser.add_argument("--wrap", default="",
                        help="a command skylit-live runs under, e.g. 'heaptrack -o OUT/live' (its sampling follows skylit-live)")
    parser.add_argument("--build", default=os.path.join(REPO, "build"))
    parser.add_argument("--bake", help="a bake of config/sample_site.yaml (default: made in OUT/bake)")
    parser.add_argument("--out", default=os.path.join(REPO, "build", "soak"))
    args = parser.parse_args()

    out = os.path.abspath(args.out)
    os.makedirs(out, exist_ok=True)
    bin_dir = os.path.join(args.build, "bin")
    bake = prepare(args, out)
    ports = {"broker": free_port(), "hmd": free_port(), "sky": free_port()}
    configs(args, out, bake, ports)
    rec = os.path.join(out, "rec")
    subprocess.run(["umount", rec], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    can_fill, mount_error = mount_tmpfs(rec, 64)
    if not can_fill:
        print(f"soak: cannot mount a tmpfs for the recordings ({mount_error}): the disk fault is left out")
    for name in os.listdir(rec):
        subprocess.run(["rm", "-rf", os.path.join(rec, name)])

    broker = Process("mosquitto", ["mosquitto", "-c", os.path.join(out, "mosquitto.conf")], out)
    wait_for(lambda: listening(ports["broker"]), 10, "mosquitto listening")
    sky = Process("sky-node", [os.path.join(bin_dir, "skylit-sky-node"), os.path.join(out, "sky.yaml"), "--headless"], out)
    hmd = Process("live", args.wrap.split() + [os.path.join(bin_dir, "skylit-live"), os.path.join(out, "hmd.yaml"), "--headless"],
                  out, target="skylit-live" if args.wrap else None)
    wait_for(lambda: status(ports["hmd"]), 60, "skylit-live's /status answering")

    faults = ["camera", "sky_node", "broker", "garbage"] + (["disk"] if can_fill else [])
    flag_of = {"camera": "camera_reconnecting", "sky_node": "sky_node_offline", "broker": "broker_unreachable",
               "disk": "recording_failing"}
    windows = []  # (fault, start, end) in seconds since the start
    samples = []
    start = time.monotonic()
    next_fault = start + args.fault_every / 2
    active = None  # (fault, started, undo)
    frames_dir = os.path.join(rec, "frames")
    k = 0
    try:
        while True:
            now = time.monotonic()
            if not hmd.running():
                raise RuntimeError("skylit-live stopped during the soak (see live.log)")
            if active is None and now >= next_fault:
                fault = faults[k % len(faults)]
                k += 1
                undo = inject(fault, out, frames_dir, sky, broker, ports)
                active = (fault, now, undo)
            elif active is not None and now >= active[1] + args.fault_for:
                active[2]()
                windows.append((active[0], active[1] - start, now - start))
                active = None
                next_fault = now + args.fault_every
            st = status(ports["hmd"])
            if st is not None:
                p = proc_sample(hmd.pid())
                p["heap_kib"] = st["memory"]["heap_in_use_bytes"] // 1024
                samples.append({"t": now - start, "frames": st["frames"], "camera_frames": st["camera"]["frames"],
                                "dropped": st["dropped_frames"], "malformed": st["camera"].get("malformed", 0),
                                "frame_ms": st["frame_time_ms"]["p50"], "flags": st["flags"],
                                "sky_drops": st["sky"].get("dropped", {}), **p})
            if active is None or active[0] != "disk":
                prune_recordings(frames_dir)
            if samples and samples[-1]["frames"] >= args.frames or now - start > args.max_seconds:
                break
            time.sleep(max(0.0, 1.0 - (time.monotonic() - now)))
    finally:
        if active is not None:
            active[2]()
            windows.append((active[0], active[1] - start, time.monotonic() - start))
        final = status(ports["hmd"])
        for p in (hmd, sky, broker):
            p.kill(signal.SIGTERM)
        subprocess.run(["umount", rec], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    report = judge(samples, windows, flag_of, final, args)
    report["disk_fault"] = can_fill
    write(os.path.join(out, "soak.json"), json.dumps(report, indent=2) + "\n")
    write_samples(os.path.join(out, "samples.csv"), samples)
    plot(os.path.join(out, "soak.png"), samples, windows, args.settle_frames)
    print(json.dumps(report, indent=2))
    return 0 if report["ok"] else 1


def inject(fault, out, frames_dir, sky, broker, ports):
    """Starts a fault; returns what ends it."""
    if fault == "camera":
        os.rename(os.path.join(out, "camera"), os.path.join(out, "camera.away"))
        return lambda: os.rename(os.path.join(out, "camera.away"), os.path.join(out, "camera"))
    if fault == "sky_node":
        sky.kill()
        return sky.start
    if fault == "broker":
        broker.kill(signal.SIGTERM)
        return lambda: (broker.start(), wait_for(lambda: listening(ports["broker"]), 10, "mosquitto back"))
    if fault == "disk":
        filler = os.path.join(os.path.dirname(frames_dir), "filler")
        subprocess.run(["dd", "if=/dev/zero", f"of={filler}", "bs=1M", "count=1024"],
                       stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        return lambda: os.remove(filler)
    if fault == "garbage":
        # A frame that does not decode, in place of one of the loop's files, and bytes on the sky topic.
        camera = os.path.join(out, "camera")
        victim = sorted(f for f in os.listdir(camera) if f.endswith(".png"))[0]
        os.rename(os.path.join(camera, victim), os.path.join(out, victim + ".kept"))
        write(os.path.join(camera, victim), "not a png")
        publish_garbage(ports["broker"])
        return lambda: os.replace(os.path.join(out, victim + ".kept"), os.path.join(camera, victim))
    raise ValueError(fault)


def publish_garbage(port):
    """An MQTT 3.1.1 CONNECT and a QoS 0 PUBLISH of bytes that are no sky, on the sky topic."""
    def packet(kind, body):
        n, length = len(body), b""
        while True:
            byte, n = n % 128, n // 128
            length += bytes([byte | (128 if n else 0)])
            if not n:
                return bytes([kind]) + length + body
    def text(s):
        return len(s).to_bytes(2, "big") + s.encode()
    connect = packet(0x10, text("MQTT") + bytes([4, 2, 0, 30]) + text("soak-garbage"))
    publish = packet(0x30, text("skylit/sample-site/sky") + b"\xa1\x00garbage that is no CBOR sky")
    with socket.create_connection(("127.0.0.1", port), timeout=5) as s:
        s.sendall(connect)
        s.recv(4)
        s.sendall(publish + bytes([0xe0, 0]))


def prune_recordings(frames_dir):
    """Keeps the newest few hundred frames: what a site would copy off and delete."""
    try:
        names = sorted(n for n in os.listdir(frames_dir) if n.endswith(".png"))
    except FileNotFoundError:
        return
    for name in names[:-200]:
        try:
            os.remove(os.path.join(frames_dir, name))
        except FileNotFoundError:
            pass
    log = os.path.join(frames_dir, "frames.csv")
    try:
        if os.path.getsize(log) > 8 << 20:
            os.truncate(log, 0)
    except FileNotFoundError:
        pass


def slope_per_10k(samples, key, settle):
    """Growth per 10^4 frames after `settle`: the median of the last tenth of the samples against
    the median of the first tenth. Medians, not a least-squares line: a fault's transient (the
    camera's reopening holds a few MiB for seconds) would otherwise steer the line."""
    points = [(s["frames"], s[key]) for s in samples if s["frames"] >= settle]
    tenth = len(points) // 10
    if tenth < 3:
        return None
    first, last = points[:tenth], points[-tenth:]
    median = lambda values: sorted(values)[len(values) // 2]
    frames = median([p[0] for p in last]) - median([p[0] for p in first])
    if frames <= 0:
        return None
    return 1e4 * (median([p[1] for p in last]) - median([p[1] for p in first])) / frames


def judge(samples, windows, flag_of, final, args):
    report = {"frames": samples[-1]["frames"] if samples else 0, "seconds": samples[-1]["t"] if samples else 0}
    heap = slope_per_10k(samples, "heap_kib", args.settle_frames)
    rss = slope_per_10k(samples, "rss_kib", args.settle_frames)
    fds = slope_per_10k(samples, "fds", args.settle_frames)
    threads = [s["threads"] for s in samples if s["frames"] >= args.settle_frames]
    report["heap_kib_per_10k_frames"] = heap
    report["rss_kib_per_10k_frames"] = rss
    report["fds_per_10k_frames"] = fds
    report["threads_min_max"] = [min(threads), max(threads)] if threads else None
    report["rss_mib_first_last"] = [samples[0]["rss_kib"] / 1024, samples[-1]["rss_kib"] / 1024] if samples else None
    settled = [s for s in samples if s["frames"] >= args.settle_frames]
    for key in ("heap_kib", "rss_kib"):
        report[key.replace("_kib", "_mib") + "_settled_min_max"] = \
            [min(s[key] for s in settled) / 1024, max(s[key] for s in settled) / 1024] if settled else None
    report["frame_ms_p50_median"] = sorted(s["frame_ms"] for s in samples)[len(samples) // 2] if samples else None
    # Growth is judged; memory given back is not a leak.
    ok = args.no_memory_goal or (heap is not None and heap < 1.0 and fds is not None and fds < 0.01)
    verdicts = []
    for i, (fault, begin, end) in enumerate(windows):
        v = {"fault": fault, "start_s": round(begin, 1), "end_s": round(end, 1)}
        flag = flag_of.get(fault)
        if flag:
            # Cleared: gone at some sample within clear_s after the fault, before the next one begins
            # (the next fault may raise the same flag: the broker away hides the sky node too).
            next_begin = windows[i + 1][1] if i + 1 < len(windows) else float("inf")
            during = [s for s in samples if begin + 2 <= s["t"] <= end]
            after = [s for s in samples if end < s["t"] <= min(end + args.clear_s, next_begin)]
            v["flag"] = flag
            v["shown"] = any(flag in s["flags"] for s in during)
            v["cleared"] = any(flag not in s["flags"] for s in after)
            if after:
                v["cleared_after_s"] = round(next(s["t"] for s in after if flag not in s["flags"]) - end, 1) if v["cleared"] else None
            ok = ok and v["shown"] and (v["cleared"] or not after)
        verdicts.append(v)
    report["faults"] = verdicts
    if final:
        read = final["camera"]["frames"]
        accounted = final["frames"] + final["dropped_frames"]  # malformed frames are not counted as read
        report["camera_frames_read"] = read
        report["camera_frames_unaccounted"] = read - accounted
        report["camera_malformed"] = final["camera"].get("malformed", 0)
        report["sky_drops"] = final["sky"].get("dropped")
        report["recording"] = final.get("recording")
        ok = ok and abs(read - accounted) <= 2
    report["ok"] = bool(ok)
    return report


def write_samples(path, samples):
    keys = ["t", "frames", "camera_frames", "dropped", "malformed", "frame_ms", "heap_kib", "rss_kib", "fds", "threads"]
    with open(path, "w") as f:
        f.write(",".join(keys) + ",flags\n")
        for s in samples:
            f.write(",".join(str(s[k]) for k in keys) + "," + " ".join(s["flags"]) + "\n")


def plot(path, samples, windows, settle_frames=0):
    """Heap in use, RSS, open files, threads and frame time against time, the faults shaded (Pillow).
    Each panel's scale spans the samples after `settle_frames` (start-up would flatten the rest);
    earlier samples are drawn clipped to it."""
    try:
        from PIL import Image, ImageDraw
    except ImportError:
        return
    if len(samples) < 2:
        return
    panels = [("heap in use (MiB)", lambda s: s["heap_kib"] / 1024),
              ("resident memory (MiB)", lambda s: s["rss_kib"] / 1024), ("open files", lambda s: s["fds"]),
              ("threads", lambda s: s["threads"]), ("frame time p50 (ms)", lambda s: s["frame_ms"])]
    w, ph, margin = 1200, 180, 60
    image = Image.new("RGB", (w, ph * len(panels) + 40), "white")
    d = ImageDraw.Draw(image)
    t_end = samples[-1]["t"]
    x_of = lambda t: margin + (w - 2 * margin) * t / max(t_end, 1e-9)
    colours = {"camera": (255, 220, 200), "sky_node": (200, 220, 255), "broker": (220, 255, 200),
               "disk": (255, 240, 180), "garbage": (230, 210, 250)}
    for i, (title, value) in enumerate(panels):
        top = 20 + i * ph
        for fault, begin, end in windows:
            d.rectangle([x_of(begin), top + 15, x_of(end), top + ph - 20], fill=colours.get(fault, (230, 230, 230)))
        values = [value(s) for s in samples]
        settled = [v for s, v in zip(samples, values) if s["frames"] >= settle_frames] or values
        lo, hi = min(settled), max(settled)
        if hi - lo < 1e-9:
            hi = lo + 1
        y_of = lambda v: top + ph - 20 - (ph - 40) * (min(max(v, lo), hi) - lo) / (hi - lo)
        d.text((margin, top), f"{title}: {lo:.4g} to {hi:.4g}", fill="black")
        d.line([(x_of(s["t"]), y_of(v)) for s, v in zip(samples, values)], fill=(20, 60, 160), width=2)
        d.rectangle([margin, top + 15, w - margin, top + ph - 20], outline=(150, 150, 150))
    d.text((margin, ph * len(panels) + 20),
           f"{samples[-1]['frames']} frames in {t_end:.0f} s; shaded: " + ", ".join(colours), fill="black")
    image.save(path)


if __name__ == "__main__":
    sys.exit(main())
