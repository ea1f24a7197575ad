// The installer's console (docs/console.md): polls /status (and /site on a sky node) twice a
// second and shows it as four views: the site's HMD nodes, the sky, the HMD, the bake.
"use strict";

const POLL_MS = 500;
const HISTORY_S = 600;        // the plots' last ten minutes
const STALE_AFTER_S = 3;      // a node publishes its status once a second

// Each flag of /status in words, with what to do.
const FLAG_WORDS = {
  no_sky_yet: ["No sky yet", "the building is hidden until the first sky arrives; check the sky camera or the sky node"],
  sky_stale: ["The sky is old", "no new sky for longer than sky.stale_after: check the sky camera, its cable, or the sky node"],
  sky_reconnecting: ["The sky camera is down", "the service reopens it with a backoff; check its power and cable"],
  camera_reconnecting: ["The HMD camera is down", "the service reopens it with a backoff; check its cable"],
  sun_clipped: ["The sun is clipped", "the sky camera saturates on the sun, so its energy is a lower bound: shorten its exposure or add an ND filter"],
  faces_unseen: ["Part of the sky is unseen", "some dome faces fall outside the sky camera's image or mask: check its aim and mask"],
  bad_pixels: ["Bad sky pixels", "the sky frame has NaN, infinite or negative values: check the camera's driver and response curve"],
  broker_unreachable: ["The site's broker is unreachable", "check the network and mosquitto on the broker machine; the node retries by itself"],
  sky_node_offline: ["The sky node is offline", "the building keeps the last sky; restart skylit-sky-node"],
  pose_lost: ["Tracking is lost", "the building fades out until the pose returns: the HMD camera must see the site's markers"],
  tracking_lost: ["Tracking is lost", "the fused pose gave up: look at the site's markers"],
  markers_not_accepted: ["Markers not trusted", "the last marker solve was rejected (too few tags or too large an error): check the marker map"],
  tracker_errors: ["The marker tracker failed", "see the service's log"],
  imu_gone: ["The IMU is gone", "check the HMD's USB cable; tracking continues on markers alone"],
};

const view = { current: "", info: null, updates: 0, bakeLoaded: false, history: [], lastSkyKey: null, lastFrameKey: null, map: null };

const $ = (selector, root = document) => root.querySelector(selector);
const field = (name, root = document) => root.querySelectorAll(`[data-field="${name}"]`);
function setField(name, text, root = document) { for (const e of field(name, root)) e.textContent = text; }
const fixed = (x, digits) => (typeof x === "number" && Number.isFinite(x) ? x.toFixed(digits) : "—");
const p50p99 = (q) => (q ? `${fixed(q.p50, 1)} ms median, ${fixed(q.p99, 1)} ms p99` : "—");

function views() {
  const names = ["sky"];
  if (view.info.site) names.unshift("site");
  if (view.info.frame) names.push("hmd");
  if (view.info.bake) names.push("bake");
  return names;
}

function show(name) {
  const names = views();
  if (!names.includes(name)) name = names[0];
  view.current = name;
  for (const n of ["site", "sky", "hmd", "bake"]) {
    $(`#view-${n}`).hidden = n !== name;
    const tab = $(`#tab-${n}`);
    tab.hidden = !names.includes(n);
    if (n === name) tab.setAttribute("aria-current", "page"); else tab.removeAttribute("aria-current");
  }
  if (name === "bake" && !view.bakeLoaded) loadBake();
  drawPlots();
}

function renderFlags(flags) {
  const list = $("#flags");
  list.replaceChildren();
  for (const flag of flags) {
    const [title, advice] = FLAG_WORDS[flag] || [flag.replaceAll("_", " "), "see docs/live.md (Faults)"];
    const item = document.createElement("li");
    item.dataset.flag = flag;
    const strong = document.createElement("strong");
    strong.textContent = title;
    item.append(strong, `: ${advice}.`);
    list.append(item);
  }
  $("#no-flags").hidden = flags.length > 0;
  $("#attention").classList.toggle("clear", flags.length === 0);
}

function renderSky(status) {
  const sky = status.sky || {};
  setField("state", status.state || "—");
  setField("sky-utc", sky.utc ? `${typeof sky.utc === "number" ? new Date(sky.utc * 1000).toISOString() : sky.utc}` : "—");
  setField("sky-age", fixed(sky.age_s ?? sky.seconds_since_frame, 1));
  const sun = sky.sun;
  setField("sun-elevation", sun ? fixed(sun.elevation_deg, 1) : "—");
  setField("sun-azimuth", sun ? fixed(sun.azimuth_deg, 1) : "—");
  setField("sun-reason", sky.sun_reason || "—");
  const expected = sky.sun_expected;
  if (expected) {
    setField("sun-expected", `${fixed(expected.elevation_deg, 1)}° up, ${fixed(expected.azimuth_deg, 1)}° from north (${expected.location})`);
    setField("sun-offset", sun ? `${fixed(expected.offset_deg, 2)}°` : "no sun found");
  } else {
    setField("sun-expected", sky.utc ? "unknown: the site file has no location (docs/site-format.md)" : "unknown: the sky frame has no time");
    setField("sun-offset", "—");
  }
  // A new sky: a new overlay (fetched once per sky, not per poll).
  const key = `${sky.estimates ?? ""}/${sky.skies_taken ?? ""}/${sky.sequence ?? ""}`;
  if (sky.age_s != null && key !== view.lastSkyKey) {  // no overlay before the first sky
    view.lastSkyKey = key;
    $("#sky-image").src = `/sky.jpg?v=${encodeURIComponent(key)}`;
  }
}

function renderHmd(status) {
  setField("frame-rate", fixed(status.frame_rate, 1));
  setField("frame-time", p50p99(status.frame_time_ms));
  setField("latency", p50p99(status.latency_ms));
  setField("opacity", fixed(status.opacity, 2));
  const fade = status.pose && status.pose.fade;
  setField("opacity-why", fade && fade.state !== "shown" ? `(${fade.state}: tracking lost)` : status.state === "waiting for sky" ? "(waiting for the first sky)" : "");
  const pose = status.pose || {};
  setField("pose-source", pose.source || "—");
  setField("tracking", pose.tracking ? `${pose.tracking.state}, confidence ${fixed(pose.tracking.confidence, 2)}` : pose.fade ? pose.fade.state : "—");
  const latest = pose.markers && pose.markers.latest;
  setField("markers", latest ? `${latest.tags_seen} (${(latest.tags_used || []).join(", ") || "none used"})` : pose.markers ? "none" : "no marker tracker");
  setField("reprojection", latest && latest.reprojection_error_px != null ? `${fixed(latest.reprojection_error_px, 2)} px` : "—");
  const blend = status.blend || {};
  setField("blend", blend.device ? `${blend.basis} basis on the ${blend.device.toUpperCase()}, ${(blend.planes || []).length} planes` : "—");
  drawMap(pose, latest);
  const key = String(status.frames);
  if (status.frames > 0 && key !== view.lastFrameKey) {  // no composite before the first frame
    view.lastFrameKey = key;
    $("#frame-image").src = `/frame.jpg?v=${key}`;
  }
}

function renderSite(site) {
  const cards = $("#node-cards");
  const seen = new Set();
  for (const node of site.nodes) {
    seen.add(node.node);
    let card = cards.querySelector(`.node-card[data-node="${CSS.escape(node.node)}"]`);
    if (!card) {
      card = document.createElement("article");
      card.className = "node-card";
      card.dataset.node = node.node;
      card.innerHTML = `<h3></h3><dl class="facts">
        <dt>State</dt><dd data-field="node-state"></dd>
        <dt>Frame rate</dt><dd><span data-field="frame-rate"></span> frames/s</dd>
        <dt>Latency</dt><dd data-field="latency"></dd>
        <dt>Sky to screen</dt><dd data-field="sky-to-screen"></dd>
        <dt>Flags</dt><dd data-field="node-flags"></dd>
        <dt>Last heard</dt><dd><span data-field="heard"></span> s ago</dd></dl>`;
      card.querySelector("h3").textContent = node.node;
      cards.append(card);
    }
    const silent = node.seconds_since_heard > STALE_AFTER_S || node.state === "offline" || node.state === "stopped";
    card.classList.toggle("stale", silent);
    setField("node-state", node.state || "—", card);
    setField("frame-rate", fixed(node.frame_rate, 1), card);
    setField("latency", node.latency_ms ? `${fixed(node.latency_ms.p50, 0)} ms` : "—", card);
    setField("sky-to-screen", node.sky_to_screen_ms ? `${fixed(node.sky_to_screen_ms.p50, 0)} ms` : "—", card);
    setField("node-flags", (node.flags || []).map((f) => (FLAG_WORDS[f] || [f])[0]).join("; ") || "none", card);
    setField("heard", fixed(node.seconds_since_heard, 1), card);
  }
  for (const card of cards.querySelectorAll(".node-card")) if (!seen.has(card.dataset.node)) card.remove();
  $("#no-nodes").hidden = site.nodes.length > 0;
  $("#site-sky").textContent = `Sky node ${site.sky.node}: ${site.sky.published} skies published (sequence ${site.sky.sequence}) on ${site.topic}/sky.`;
}

// The site from above (x east, y north): planes outlined, tags as squares, the ones the last
// solve used filled, and the HMD camera's position.
function drawMap(pose, latest) {
  const svg = $("#site-map");
  if (!view.map || !svg) return;
  const points = view.map.planes.flatMap((p) => p.corners).concat(view.map.tags.flatMap((t) => t.corners));
  if (!points.length) return;
  const xs = points.map((c) => c[0]), ys = points.map((c) => c[1]);
  const pad = 1, x0 = Math.min(...xs) - pad, x1 = Math.max(...xs) + pad, y0 = Math.min(...ys) - pad, y1 = Math.max(...ys) + pad;
  svg.setAttribute("viewBox", `${x0} ${-y1} ${x1 - x0} ${y1 - y0}`);
  const used = new Set((latest && latest.tags_used) || []);
  const path = (corners) => corners.map((c, i) => `${i ? "L" : "M"}${c[0]} ${-c[1]}`).join(" ") + " Z";
  const stroke = Math.max(x1 - x0, y1 - y0) / 300;
  let html = view.map.planes.map((p) => `<path d="${path(p.corners)}" fill="none" stroke="#1d1d1d" stroke-width="${stroke * 2}"><title>${p.name}</title></path>`).join("");
  // A tag is a few decimetres on a site of tens of metres: drawn as a ring with its id, filled when used.
  html += view.map.tags.map((t) => {
    const cx = t.corners.reduce((s, c) => s + c[0], 0) / 4, cy = -t.corners.reduce((s, c) => s + c[1], 0) / 4;
    const seen = used.has(t.id);
    return `<g data-tag="${t.id}"${seen ? ' class="seen"' : ""}><circle cx="${cx}" cy="${cy}" r="${stroke * 7}" fill="${seen ? "#0037a3" : "#fff"}" stroke="#0037a3" stroke-width="${stroke * 2}"/>` +
      `<text x="${cx + stroke * 9}" y="${cy + stroke * 4}" font-size="${stroke * 14}" fill="#0b0b0b">${t.id}</text><title>tag ${t.id}${seen ? ": seen" : ""}</title></g>`;
  }).join("");
  const at = pose && pose.last && pose.last.position;
  if (at) html += `<circle cx="${at[0]}" cy="${-at[1]}" r="${stroke * 8}" fill="#b00000"><title>the HMD camera</title></circle>`;
  svg.innerHTML = html;
}

async function loadBake() {
  try {
    const bake = await (await fetch("/bake.json")).json();
    view.bakeLoaded = true;
    const facts = $("#bake-facts");
    facts.replaceChildren();
    const made = bake.made_for;
    for (const [k, v] of [["Bake", bake.bake], ["Made for", made.site_file], ["Dome", `ν = ${made.frequency}, ${made.basis} basis, ${made.layers} layers`],
                          ["Samples", `${made.samples} per face, ${made.method}`], ["Preset", made.preset || "none"],
                          ["Made", `${bake.created_utc} by ${bake.generator}`]]) {
      const dt = document.createElement("dt"); dt.textContent = k;
      const dd = document.createElement("dd"); dd.textContent = v;
      facts.append(dt, dd);
    }
    const verify = $("#bake-verify");
    verify.className = bake.verify.ok ? "ok" : "problem";
    verify.textContent = bake.verify.ok ? "Verified: every file matches the manifest." : `Verify failed: ${bake.verify.problems.join("; ")}`;
    const body = $("#bake-planes tbody");
    body.replaceChildren();
    for (const plane of bake.planes) {
      const row = document.createElement("tr");
      row.dataset.plane = plane.name;
      const cells = [plane.name, `${plane.resolution[0]} × ${plane.resolution[1]}`, `${fixed(plane.size_m[0], 1)} × ${fixed(plane.size_m[1], 1)} m`];
      for (const text of cells) { const td = document.createElement("td"); td.textContent = text; row.append(td); }
      const td = document.createElement("td");
      if (plane.preview) {
        const img = document.createElement("img");
        img.className = "preview";
        img.src = plane.preview;
        img.alt = `The bake's preview of plane ${plane.name}: its shadow layers`;
        td.append(img);
      } else td.textContent = "no preview";
      row.append(td);
      body.append(row);
    }
  } catch (error) {
    $("#bake-verify").textContent = `The bake could not be read: ${error}`;
  }
}

function remember(status) {
  const now = Date.now() / 1000;
  const S = status.sky && status.sky.S;
  let mean = null;
  if (Array.isArray(S) && S.length) {
    mean = [0, 1, 2].map((c) => S.reduce((sum, v) => sum + v[c], 0) / S.length);
  }
  view.history.push({ t: now, mean, frame: status.frame_time_ms ? status.frame_time_ms.p50 : null, latency: status.latency_ms ? status.latency_ms.p50 : null });
  while (view.history.length && view.history[0].t < now - HISTORY_S) view.history.shift();
}

// A line plot of series over the history's time, with its scale in words.
function plot(canvas, series, unit) {
  const ctx = canvas.getContext("2d");
  const w = canvas.width, h = canvas.height, left = 60, bottom = 24;
  ctx.fillStyle = "#fff"; ctx.fillRect(0, 0, w, h);
  const points = view.history;
  const values = series.flatMap((s) => points.map(s.value).filter((v) => v != null && Number.isFinite(v)));
  ctx.strokeStyle = "#1d1d1d"; ctx.lineWidth = 2; ctx.strokeRect(left, 4, w - left - 4, h - bottom - 4);
  ctx.fillStyle = "#0b0b0b"; ctx.font = "16px system-ui, sans-serif";
  if (values.length < 2) { ctx.fillText("collecting…", left + 10, h / 2); return; }
  const top = Math.max(...values) * 1.1 || 1, t0 = points[0].t, t1 = points[points.length - 1].t || t0 + 1;
  ctx.fillText(`${top.toPrecision(3)}`, 4, 18); ctx.fillText(`0 ${unit}`, 4, h - bottom);
  ctx.fillText(`${Math.round(t1 - t0)} s`, w - 60, h - 4);
  series.forEach((s, i) => {
    ctx.strokeStyle = s.color; ctx.lineWidth = 3; ctx.beginPath();
    let started = false;
    for (const p of points) {
      const v = s.value(p);
      if (v == null || !Number.isFinite(v)) continue;
      const x = left + (w - left - 8) * (t1 > t0 ? (p.t - t0) / (t1 - t0) : 1);
      const y = 4 + (h - bottom - 8) * (1 - v / top);
      if (started) ctx.lineTo(x, y); else { ctx.moveTo(x, y); started = true; }
    }
    ctx.stroke();
    ctx.fillStyle = s.color; ctx.fillText(s.label, left + 10 + i * 150, h - 6);
  });
}

function drawPlots() {
  if (view.current === "sky") {
    plot($("#s-plot"), [
      { label: "S red", color: "#b00000", value: (p) => p.mean && p.mean[0] },
      { label: "S green", color: "#006b00", value: (p) => p.mean && p.mean[1] },
      { label: "S blue", color: "#0037a3", value: (p) => p.mean && p.mean[2] }], "");
  } else if (view.current === "hmd") {
    plot($("#time-plot"), [
      { label: "frame time p50", color: "#0037a3", value: (p) => p.frame },
      { label: "latency p50", color: "#b00000", value: (p) => p.latency }], "ms");
  }
}

async function poll() {
  try {
    const status = await (await fetch("/status", { cache: "no-store" })).json();
    renderFlags(status.flags || []);
    renderSky(status);
    if (view.info.frame) renderHmd(status);
    if (view.info.site) renderSite(await (await fetch("/site", { cache: "no-store" })).json());
    remember(status);
    drawPlots();
    view.updates += 1;
    document.body.dataset.updates = String(view.updates);
    const connection = $("#connection");
    connection.textContent = `Live · updated ${new Date().toLocaleTimeString()}`;
    connection.classList.remove("down");
  } catch (error) {
    const connection = $("#connection");
    connection.textContent = `No answer from the service (${error.message}); retrying`;
    connection.classList.add("down");
  }
  setTimeout(poll, POLL_MS);
}

async function start() {
  view.info = await (await fetch("/console.json")).json();
  $("#title").textContent = view.info.title;
  document.title = `${view.info.title} console`;
  window.addEventListener("hashchange", () => show(location.hash.slice(1)));
  show(location.hash.slice(1));
  if (view.info.map) view.map = await (await fetch("/map.json")).json();
  // The plots start with the node's last minutes, kept by the node itself.
  const answer = await fetch("/history.json");
  if (answer.ok) {
    const now = Date.now() / 1000;
    view.history = (await answer.json()).samples.map((p) => ({ t: now - p.age_s, mean: p.S, frame: p.frame_ms, latency: p.latency_ms }));
  }
  poll();
}

start();
