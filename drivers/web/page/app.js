// rutd live view: polls /api/live.json four times a second and /api/history.json once a second
// (docs/web.md), and draws what they say. No framework; nothing is fetched from outside rutd.
'use strict';

const token = new URLSearchParams(location.search).get('token');
const withToken = (path) => (token ? path + (path.includes('?') ? '&' : '?') + 'token=' + encodeURIComponent(token) : path);
const $ = (id) => document.getElementById(id);
const fixed = (v, d) => (v === null || v === undefined ? '-' : Number(v).toFixed(d));
const percent = (v) => (v === null || v === undefined ? '-' : (100 * v).toFixed(1) + ' %');
let updates = 0;
let failures = 0;

async function getJson(path) {
  const response = await fetch(withToken(path), { cache: 'no-store' });
  if (!response.ok) throw new Error(path + ': ' + response.status + ' ' + (await response.text()));
  return response.json();
}

// A picture is replaced only once the new one has loaded, so the page never flickers to empty; data-seq
// says which pair the shown picture is of.
function showImage(img, path, seq) {
  if (!path) return;
  if (img.dataset.wanted === String(seq)) return;
  img.dataset.wanted = String(seq);
  const next = new Image();
  next.onload = () => {
    img.src = next.src;
    img.dataset.seq = String(seq);
    img.dataset.width = String(next.naturalWidth);
    img.dataset.loads = String(Number(img.dataset.loads || 0) + 1);
  };
  next.src = withToken(path + '?seq=' + seq);
}

function drawHistogram(canvas, bins) {
  const g = canvas.getContext('2d');
  g.clearRect(0, 0, canvas.width, canvas.height);
  const max = Math.max(1, ...bins);
  const w = canvas.width / bins.length;
  bins.forEach((n, i) => {
    const h = (canvas.height * n) / max;
    g.fillStyle = i === bins.length - 1 && n > 0 ? '#b3261e' : '#4a5a66';
    g.fillRect(i * w, canvas.height - h, Math.max(1, w - 1), h);
  });
}

function showCamera(side, a) {
  $('focus-' + side).textContent = fixed(a.focus, 0);
  $('mean-' + side).textContent = percent(a.mean);
  $('sat-' + side).textContent = percent(a.saturated_share);
  $('dark-' + side).textContent = percent(a.dark_share);
  drawHistogram($('hist-' + side), a.histogram);
}

function drawSection(canvas, s) {
  const g = canvas.getContext('2d');
  g.clearRect(0, 0, canvas.width, canvas.height);
  if (!s) return;
  const pts = s.x_mm.map((x, i) => [x, s.z_mm[i]]).filter((p) => p[1] !== null);
  if (pts.length < 2) return;
  const xs = pts.map((p) => p[0]);
  const zs = pts.map((p) => p[1]);
  const x0 = Math.min(...xs), x1 = Math.max(...xs);
  const z0 = Math.min(...zs) - 5, z1 = Math.max(...zs) + 5;
  // Z grows away from the camera, so deeper is further down the canvas.
  const px = (x) => ((x - x0) / Math.max(1e-9, x1 - x0)) * (canvas.width - 20) + 10;
  const py = (z) => ((z - z0) / Math.max(1e-9, z1 - z0)) * (canvas.height - 20) + 10;
  g.fillStyle = '#4a5a66';
  pts.forEach((p) => g.fillRect(px(p[0]) - 1, py(p[1]) - 1, 2, 2));
  if (s.ground_line) {
    g.strokeStyle = '#2e7d32';
    g.beginPath();
    g.moveTo(px(x0), py(s.ground_line.m * x0 + s.ground_line.c_mm));
    g.lineTo(px(x1), py(s.ground_line.m * x1 + s.ground_line.c_mm));
    g.stroke();
  }
  if (s.water) {
    g.strokeStyle = '#1565c0';
    g.beginPath();
    const zl = (x) => s.ground_line.m * x + s.ground_line.c_mm + s.water.level_mm;
    g.moveTo(px(s.water.left_x_mm), py(zl(s.water.left_x_mm)));
    g.lineTo(px(s.water.right_x_mm), py(zl(s.water.right_x_mm)));
    g.stroke();
  }
  if (s.rut) {
    g.fillStyle = '#e0a800';
    for (const x of [s.rut.left_x_mm, s.rut.right_x_mm]) {
      g.beginPath();
      g.arc(px(x), py(s.ground_line.m * x + s.ground_line.c_mm), 5, 0, 2 * Math.PI);
      g.fill();
    }
    g.fillStyle = '#d32f2f';
    g.beginPath();
    g.arc(px(s.rut.deepest_x_mm), py(s.rut.deepest_z_mm), 6, 0, 2 * Math.PI);
    g.fill();
  }
}

function drawHistory(canvas, h) {
  const g = canvas.getContext('2d');
  g.clearRect(0, 0, canvas.width, canvas.height);
  const end = h.bins.length ? h.bins[h.bins.length - 1].t_s : 0;
  const depths = h.bins.map((b) => b.depth_max_mm).filter((d) => d !== null);
  const top = Math.max(10, ...depths) * 1.1;
  const px = (t) => canvas.width - ((end - t) / 60) * canvas.width;
  const py = (d) => (d / top) * (canvas.height - 20) + 10;  // depth downwards, as in the ground
  g.fillStyle = '#333';
  g.fillText('0 mm', 2, 16);
  g.fillText(top.toFixed(0) + ' mm', 2, canvas.height - 2);
  // The advisory of each segment closed in the last minute, as a band along the top.
  const colours = { GO: '#2e7d32', CAUTION: '#e0a800', NO_GO: '#b3261e', UNKNOWN: '#9e9e9e' };
  for (const s of h.segments) {
    if (s.t_end_s === null || end - s.t_end_s > 60) continue;
    const x0 = Math.max(0, px(s.t_start_s)), x1 = Math.max(x0 + 1, px(s.t_end_s));
    g.fillStyle = colours[s.advisory] || '#9e9e9e';
    g.fillRect(x0, 0, x1 - x0, 6);
  }
  for (const b of h.bins) {
    const x = px(b.t_s);
    if (b.worst_status !== 'OK' && b.worst_status !== 'NO_RUT') {
      g.fillStyle = 'rgba(179, 38, 30, 0.25)';
      g.fillRect(x, 0, Math.max(1, canvas.width / 600), canvas.height);
    }
    if (b.depth_max_mm !== null) {
      g.fillStyle = '#23303a';
      g.fillRect(x, py(b.depth_max_mm) - 1, Math.max(2, canvas.width / 600), 3);
    }
  }
}

function showBits(list, bits) {
  list.replaceChildren(
    ...bits.map((b) => {
      const li = document.createElement('li');
      li.id = list.id + '-' + b.name;
      li.className = b.set ? 'set' : '';
      const name = document.createElement('b');
      name.textContent = b.name + (b.set ? ' ●' : '');
      li.append(name, ' ' + b.meaning);
      return li;
    })
  );
}

function showLive(d) {
  $('seq').textContent = d.seq;
  $('age').textContent = fixed(d.age_s, 1);
  $('status').textContent = d.status;
  $('status-meaning').textContent = d.status_meaning;
  const lost = d.health.some((b) => b.name === 'NoCamera' && b.set);
  $('status-box').className = 'badge ' + (lost ? 'lost' : d.status === 'OK' ? 'ok' : 'refused');
  $('advisory').textContent = d.advisory;
  $('advisory-box').className = 'badge advisory ' + d.advisory;
  const m = d.measurement;
  $('depth').textContent = fixed(m.depth_mm, 2);
  $('uncertainty').textContent = fixed(m.depth_uncertainty_mm, 2);
  $('width').textContent = fixed(m.width_mm, 1);
  $('area').textContent = fixed(m.area_mm2, 0);
  $('left-pile').textContent = fixed(m.left_pile_mm, 1);
  $('right-pile').textContent = fixed(m.right_pile_mm, 1);
  $('slope').textContent = fixed(m.ground_slope_deg, 2);
  $('quality').textContent = percent(m.quality);
  $('valid').textContent = percent(m.valid_fraction);
  $('vdisp').textContent = fixed(m.vertical_disparity_px, 2);
  $('skew').textContent = fixed(d.aiming.skew_ms, 2);
  $('rate').textContent = fixed(d.frame_rate_hz, 1);
  $('published-rate').textContent = fixed(d.aiming.published_rate_hz, 1);
  $('dropped').textContent = d.dropped_frames;
  $('speed').textContent = d.motion.speed_km_h === null ? d.motion.speed : fixed(d.motion.speed_km_h, 1) + ' km/h';
  $('distance').textContent = fixed(d.motion.distance_m, 1);
  showCamera('left', d.aiming.left);
  showCamera('right', d.aiming.right);
  showImage($('img-left'), d.images.left, d.seq);
  showImage($('img-right'), d.images.right, d.seq);
  showImage($('img-strip'), d.images.strip, d.seq);
  drawSection($('section'), d.section);
  showBits($('conditions'), d.conditions);
  showBits($('health'), d.health);
  const s = d.last_segment;
  $('last-segment').textContent = s
    ? `segment ${s.index} (${fixed(s.start_m, 1)}–${fixed(s.end_m, 1)} m): P95 depth ${fixed(s.p95_depth_mm, 1)} mm, ` +
      `worst ${s.worst_status}, advisory ${s.advisory}; ${d.segments} segments so far`
    : 'no segment closed yet (segments need the vehicle speed)';
  const v = d.view;
  $('view-stats').textContent = `view: ${v.pairs_offered} pairs shown, ${v.pairs_dropped} dropped, ${v.requests} requests`;
}

async function pollLive() {
  try {
    showLive(await getJson('api/live.json'));
    failures = 0;
    $('connection').textContent = 'live';
    $('connection').className = 'badge ok';
    $('updates').textContent = String(++updates);
  } catch (e) {
    ++failures;
    $('connection').textContent = 'no answer from rutd (' + e.message + ')';
    $('connection').className = 'badge lost';
  }
  setTimeout(pollLive, failures ? 1000 : 250);
}

async function pollHistory() {
  try {
    drawHistory($('history'), await getJson('api/history.json'));
  } catch (e) {
    // pollLive reports the connection.
  }
  setTimeout(pollHistory, 1000);
}

pollLive();
pollHistory();
