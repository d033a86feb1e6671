// The live page: one event stream from the viewer (/events) says what is new; pictures and data are fetched
// from /api/... when it says so. window.viewerState holds what the page shows, for people debugging the page
// and for the browser tests (tests/viewer).
'use strict';
const state = window.viewerState = {
  connected: false, events: 0, imageUpdates: 0, imageSeq: -1, rightUpdates: 0, disparityUpdates: 0,
  disparitySeq: -1, trajectoryPoints: {}, trajectoryReloads: 0, healthRows: [], cloudPoints: 0, mapPoints: 0,
  errors: [],
};
window.addEventListener('error', e => state.errors.push(String(e.message)));
const consoleError = console.error.bind(console);
console.error = (...a) => { state.errors.push(a.map(String).join(' ')); consoleError(...a); };

const $ = id => document.getElementById(id);

// --- images: the newest one is fetched when an event announces it; one request at a time per picture, so a
// slow link shows fewer pictures instead of a growing backlog.
function pictureLoader(img, onShown) {
  let busy = false, wanted = null;
  img.addEventListener('load', () => { busy = false; onShown(); if (wanted) load(wanted); });
  img.addEventListener('error', () => { busy = false; });
  function load(url) {
    if (busy) { wanted = url; return; }
    busy = true; wanted = null; img.src = url;
  }
  return load;
}
const loadLeft = pictureLoader($('left'), () => { state.imageUpdates++; });
const loadRight = pictureLoader($('right'), () => { state.rightUpdates++; });
const loadDisparity = pictureLoader($('disparity'), () => { state.disparityUpdates++; });
$('show-right').addEventListener('change', e => { $('right-figure').hidden = !e.target.checked; });

function onImage(m) {
  state.imageSeq = m.seq;
  $('left-info').textContent = `seq ${m.seq}, t = ${(m.utime * 1e-6).toFixed(2)} s`;
  $('clock').textContent = `sensor time ${(m.utime * 1e-6).toFixed(1)} s`;
  loadLeft(`/api/left.jpg?seq=${m.seq}`);
  // The viewer encodes the right image only for the pages that ask for it.
  if ($('show-right').checked) loadRight(`/api/right.jpg?seq=${m.seq}`);
}

function onDisparity(m) {
  state.disparitySeq = m.seq;
  $('disparity-info').textContent =
      `seq ${m.seq}, t = ${(m.utime * 1e-6).toFixed(2)} s, ${m.valid_pct.toFixed(1)} % of the pixels with a disparity`;
  loadDisparity(`/api/disparity.png?seq=${m.seq}`);
  const ticks = $('colourbar-ticks');
  ticks.innerHTML = '';
  const n = 5;
  for (let i = 0; i <= n; i++) {
    const s = document.createElement('span');
    s.style.left = `${100 * i / n}%`;
    s.textContent = (m.min + (m.max - m.min) * i / n).toFixed(0);
    ticks.appendChild(s);
  }
  if (state.mapPoints === 0) loadCloud('/api/cloud.bin', 'camera');
}

// --- trajectory: Chart.js scatter with lines, one dataset per source, the 3-sigma ellipse of each filter's
// newest position, axes at one scale.
const colours = { truth: '#222', EKF: '#d62728', UKF: '#1f77b4' };
const dashes = { truth: [6, 4], EKF: [], UKF: [2, 2] };
const tracks = {};  // source -> array of points [t, x, y, z, vxx, vxy, vyy]
const chart = new Chart($('trajectory'), {
  type: 'scatter',
  data: { datasets: [] },
  options: {
    animation: false, maintainAspectRatio: false, parsing: false, normalized: true,
    elements: { point: { radius: 0 } },
    scales: {
      x: { type: 'linear', title: { display: true, text: 'x [m] (world, local level)' } },
      y: { type: 'linear', title: { display: true, text: 'y [m]' } },
    },
    plugins: { legend: { position: 'top' }, tooltip: { enabled: false } },
  },
});

function ellipse(p, k) {
  // 3-sigma ellipse of the 2x2 position covariance [vxx vxy; vxy vyy], as a closed polyline.
  const a = p[4], b = p[5], c = p[6];
  const tr = (a + c) / 2, det = Math.sqrt(Math.max(0, ((a - c) / 2) ** 2 + b * b));
  const l1 = tr + det, l2 = Math.max(0, tr - det);
  const th = 0.5 * Math.atan2(2 * b, a - c);
  const pts = [];
  for (let i = 0; i <= 36; i++) {
    const u = 2 * Math.PI * i / 36;
    const ex = k * Math.sqrt(l1) * Math.cos(u), ey = k * Math.sqrt(l2) * Math.sin(u);
    pts.push({ x: p[1] + ex * Math.cos(th) - ey * Math.sin(th), y: p[2] + ex * Math.sin(th) + ey * Math.cos(th) });
  }
  return pts;
}

let chartDirty = false;
function redrawTrajectory() {
  chartDirty = false;
  const sets = [];
  let minX = Infinity, maxX = -Infinity, minY = Infinity, maxY = -Infinity;
  for (const name of Object.keys(tracks).sort()) {
    const pts = tracks[name].map(p => ({ x: p[1], y: p[2] }));
    for (const p of pts) { minX = Math.min(minX, p.x); maxX = Math.max(maxX, p.x); minY = Math.min(minY, p.y); maxY = Math.max(maxY, p.y); }
    const colour = colours[name] || '#2ca02c';
    sets.push({ label: name === 'truth' ? 'ground truth' : name, data: pts, showLine: true, borderColor: colour,
                backgroundColor: colour, borderDash: dashes[name] || [], borderWidth: 2 });
    const last = tracks[name][tracks[name].length - 1];
    if (name !== 'truth' && last && last[4] > 0)
      sets.push({ label: `${name} 3\u03c3`, data: ellipse(last, 3), showLine: true, borderColor: colour,
                  backgroundColor: colour, borderWidth: 1, borderDash: [1, 2] });
  }
  chart.data.datasets = sets;
  if (isFinite(minX)) {
    // One metre is as long on both axes: a top view must not bend the path.
    const w = chart.chartArea ? chart.chartArea.width : 400, h = chart.chartArea ? chart.chartArea.height : 300;
    const cx = (minX + maxX) / 2, cy = (minY + maxY) / 2;
    const span = Math.max((maxX - minX) / w, (maxY - minY) / h, 2 / Math.min(w, h)) * 1.1;
    chart.options.scales.x.min = cx - span * w / 2; chart.options.scales.x.max = cx + span * w / 2;
    chart.options.scales.y.min = cy - span * h / 2; chart.options.scales.y.max = cy + span * h / 2;
  }
  chart.update('none');
  const info = Object.keys(tracks).sort().map(n => `${n}: ${tracks[n].length} points`).join(', ');
  $('trajectory-info').textContent = info + ' (filters put on the ground truth at their first pose when it is on the bus)';
  for (const n of Object.keys(tracks)) state.trajectoryPoints[n] = tracks[n].length;
}
setInterval(() => { if (chartDirty) redrawTrajectory(); }, 500);

let generation = -1, reloading = false;
async function reloadTrajectory() {
  if (reloading) return;
  reloading = true;
  try {
    const r = await fetch('/api/trajectory.json');
    const m = await r.json();
    for (const k of Object.keys(tracks)) delete tracks[k];
    for (const [name, s] of Object.entries(m.sources)) tracks[name] = s.points;
    generation = m.generation;
    state.trajectoryReloads++;
    chartDirty = true;
  } catch (e) { /* the next event retries */ } finally { reloading = false; }
}

function onTrajectory(m) {
  if (m.generation !== generation) return reloadTrajectory();
  for (const [name, s] of Object.entries(m.sources)) {
    const have = tracks[name] || (tracks[name] = []);
    if (s.from > have.length) return reloadTrajectory();  // events were dropped for this page: catch up
    if (s.from + s.points.length > have.length) have.push(...s.points.slice(have.length - s.from));
  }
  chartDirty = true;
}

// --- 3D: three.js points, orbit controls; the mapper's georeferenced points once there are any, else the
// newest disparity map in the camera frame.
const cloudDiv = $('cloud');
const renderer = new THREE.WebGLRenderer({ antialias: false, preserveDrawingBuffer: true });
renderer.setClearColor(0x101018);
cloudDiv.appendChild(renderer.domElement);
const scene = new THREE.Scene();
const camera = new THREE.PerspectiveCamera(60, 1, 0.05, 2000);
camera.position.set(0, 3, 8);
const controls = new THREE.OrbitControls(camera, renderer.domElement);
scene.add(new THREE.AxesHelper(1));
let points = null;
function resize3d() {
  const w = cloudDiv.clientWidth, h = cloudDiv.clientHeight;
  renderer.setSize(w, h); camera.aspect = w / h; camera.updateProjectionMatrix();
}
window.addEventListener('resize', resize3d);
resize3d();
(function animate() { requestAnimationFrame(animate); controls.update(); renderer.render(scene, camera); })();

let cloudBusy = false, cloudFrame = '';
async function loadCloud(url, frame) {
  if (cloudBusy) return;
  cloudBusy = true;
  try {
    const r = await fetch(url);
    if (!r.ok) return;
    const f = new Float32Array(await r.arrayBuffer());
    const n = f.length / 3;
    const pos = new Float32Array(f.length), col = new Float32Array(f.length);
    let zmin = Infinity, zmax = -Infinity;
    for (let i = 0; i < n; i++) {
      // three.js: y up. Camera frame (x right, y down, z forward) -> (x, -y, -z); world (z up) -> (x, z, -y).
      const x = f[3 * i], y = f[3 * i + 1], z = f[3 * i + 2];
      if (frame === 'camera') { pos[3 * i] = x; pos[3 * i + 1] = -y; pos[3 * i + 2] = -z; }
      else { pos[3 * i] = x; pos[3 * i + 1] = z; pos[3 * i + 2] = -y; }
      const c = frame === 'camera' ? z : f[3 * i + 2];
      zmin = Math.min(zmin, c); zmax = Math.max(zmax, c);
    }
    for (let i = 0; i < n; i++) {
      // Coloured by depth (camera) or height (world), blue near/low to red far/high.
      const c = frame === 'camera' ? f[3 * i + 2] : f[3 * i + 2];
      const colour = new THREE.Color().setHSL(0.66 * (1 - (c - zmin) / Math.max(1e-6, zmax - zmin)), 1, 0.5);
      col[3 * i] = colour.r; col[3 * i + 1] = colour.g; col[3 * i + 2] = colour.b;
    }
    const geometry = new THREE.BufferGeometry();
    geometry.setAttribute('position', new THREE.BufferAttribute(pos, 3));
    geometry.setAttribute('color', new THREE.BufferAttribute(col, 3));
    if (points) { scene.remove(points); points.geometry.dispose(); }
    points = new THREE.Points(geometry, new THREE.PointsMaterial({ size: 2, sizeAttenuation: false, vertexColors: THREE.VertexColors }));
    scene.add(points);
    if (frame !== cloudFrame) {
      cloudFrame = frame;
      geometry.computeBoundingSphere();
      const s = geometry.boundingSphere;
      controls.target.copy(s.center);
      // Camera frame: seen from just behind and above the head, as the camera sees it; the map: from above.
      if (frame === 'camera') camera.position.set(0, 0.2 * s.radius, 0.3 * s.radius);
      else camera.position.copy(s.center).add(new THREE.Vector3(0, s.radius * 1.2, s.radius * 0.8));
      $('cloud-title').textContent = frame === 'camera' ? '3D: latest disparity map (camera frame)' : '3D: map (world frame)';
    }
    if (frame === 'camera') state.cloudPoints = n; else state.mapPoints = n;
  } catch (e) { /* next event */ } finally { cloudBusy = false; }
}

// --- health table: one row per process, red when its reports stopped.
function fmt(v, d) { return typeof v === 'number' ? v.toFixed(d) : ''; }
function onHealth(m) {
  const body = $('health').tBodies[0];
  body.innerHTML = '';
  state.healthRows = [];
  for (const r of m.rows) {
    const tr = document.createElement('tr');
    if (r.stale) tr.className = 'stale';
    const integrity = Object.keys(r.counters).filter(k => k.startsWith('integrity'))
                          .map(k => `${k.replace('integrity_', '')} ${r.counters[k]}`).join(', ') || '\u2013';
    const cells = [r.process, `${r.host}:${r.pid}`, fmt(r.input_rate_hz, 1), fmt(r.output_rate_hz, 1),
                   fmt(r.latency_ms, 1), r.queue_length, r.received, r.dropped, r.bad, integrity,
                   r.stale ? `stopped (${r.age_s.toFixed(0)} s ago)` : `${r.age_s.toFixed(1)} s ago`];
    cells.forEach((c, i) => {
      const td = document.createElement('td');
      td.textContent = c;
      if ((i === 7 || i === 8) && c > 0) td.className = 'warn';
      tr.appendChild(td);
    });
    body.appendChild(tr);
    state.healthRows.push({ process: r.process, stale: r.stale });
  }
}

function onMap(m) { if (m.points > 0) loadCloud('/api/map.bin', 'world'); }

// --- the event stream; the browser reconnects by itself when the viewer restarts.
function connect() {
  const es = new EventSource('/events');
  es.onopen = () => {
    state.connected = true;
    $('connection').textContent = 'live'; $('connection').className = 'ok';
    reloadTrajectory();
  };
  es.onerror = () => {
    state.connected = false;
    $('connection').textContent = 'viewer unreachable, retrying'; $('connection').className = 'bad';
  };
  const on = (name, fn) => es.addEventListener(name, e => { state.events++; fn(JSON.parse(e.data)); });
  on('image', onImage);
  on('disparity', onDisparity);
  on('trajectory', onTrajectory);
  on('health', onHealth);
  on('map', onMap);
}
connect();
