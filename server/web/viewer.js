// rtpm viewer: WebSocket client of rtpm-server's viewer. Draws the frames it is sent (JPEG, each
// acknowledged so the server sends the newest next), shows the figures, and turns mouse and form
// input into controls that go through the master's edit path. No dependencies, no build step.
'use strict';

const $ = (id) => document.getElementById(id);
const state = {
  ws: null, control: false, scene: null, status: null, camera: null,
  framesDrawn: 0, lastFrame: -1, errors: [], oks: [], lastScript: null, events: [], epochs: [], modes: [],
  chart: [], lag: { n: 0, sum: 0, max: 0 }, heldAck: null,
};
window.rtpmViewer = state;  // figures for tests and the curious

const COLOURS = ['#e06c75', '#61afef', '#98c379', '#e5c07b', '#c678dd', '#56b6c2', '#d19a66', '#abb2bf'];
const ownerColour = (id) => (id === 0 || id === undefined) ? '#333' : COLOURS[(id - 1) % COLOURS.length];

// ---- vectors -----------------------------------------------------------------------------
const add = (a, b) => [a[0] + b[0], a[1] + b[1], a[2] + b[2]];
const sub = (a, b) => [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
const mul = (a, s) => [a[0] * s, a[1] * s, a[2] * s];
const dot = (a, b) => a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
const cross = (a, b) => [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]];
const len = (a) => Math.sqrt(dot(a, a));
const norm = (a) => mul(a, 1 / (len(a) || 1));
function rotate(v, axis, angle) {  // Rodrigues
  const k = norm(axis), c = Math.cos(angle), s = Math.sin(angle);
  return add(add(mul(v, c), mul(cross(k, v), s)), mul(k, dot(k, v) * (1 - c)));
}

// ---- connection ------------------------------------------------------------------------------
function token() {
  const m = /(?:^|[#&])token=([^&]*)/.exec(location.hash);
  if (m) return decodeURIComponent(m[1]);
  return sessionStorage.getItem('rtpm-token') || '';
}

function send(obj) {
  if (state.ws && state.ws.readyState === WebSocket.OPEN) state.ws.send(JSON.stringify(obj));
}

function connect() {
  const ws = new WebSocket(`ws://${location.host}/ws`);
  ws.binaryType = 'arraybuffer';
  state.heldAck = null;
  state.ws = ws;
  ws.onopen = () => {
    send({ type: 'hello', token: token() });
    sendDisplay();
  };
  ws.onmessage = (ev) => {
    if (typeof ev.data === 'string') onText(JSON.parse(ev.data));
    else onFrame(ev.data);
  };
  ws.onclose = () => {
    $('access').textContent = 'disconnected';
    state.ws = null;
  };
}

function showError(message) {
  state.errors.push(message);
  const e = $('error');
  e.textContent = message;
  e.hidden = false;
  clearTimeout(showError.timer);
  showError.timer = setTimeout(() => { e.hidden = true; }, 8000);
}

function notice(text) {
  state.oks.push(text);
  $('notice').textContent = text;
}

function onText(msg) {
  switch (msg.type) {
    case 'hello':
      state.control = msg.control;
      document.body.classList.toggle('read-only', !msg.control);
      $('access').textContent = msg.control ? 'controls on' : 'read-only';
      $('token-form').hidden = msg.control;
      break;
    case 'scene': onScene(msg); break;
    case 'status': onStatus(msg); break;
    case 'event': onEvent(msg); break;
    case 'error': showError(msg.message); if (/token/.test(msg.message)) $('token-form').hidden = false; break;
    case 'ok': notice(msg.what); break;
    case 'script': saveScript(msg.text); break;
  }
}

// The master sends the next frame only after this one is acknowledged, and the page acknowledges
// a frame once it is drawn: it never gets frames faster than it draws them. A hidden tab holds
// its acknowledgement until it is shown again, so it receives no frames and costs the master
// nothing. (Acknowledging at the next animation frame instead cost a third of the frames at
// 30 fps: the acknowledgement came after the master's next frame, which then nobody wanted.)
async function onFrame(buf) {
  const view = new DataView(buf);
  const frame = view.getUint32(0, true) + view.getUint32(4, true) * 4294967296;
  const bitmap = await createImageBitmap(new Blob([new Uint8Array(buf, 8)], { type: 'image/jpeg' }));
  const c = $('frame-canvas');
  if (c.width !== bitmap.width || c.height !== bitmap.height) { c.width = bitmap.width; c.height = bitmap.height; }
  c.getContext('2d').drawImage(bitmap, 0, 0);
  bitmap.close();
  state.framesDrawn++;
  state.lastFrame = frame;
  // Lag as the page sees it: the newest frame the master reported minus the one drawn.
  const lag = state.status ? Math.max(0, state.status.frame - frame) : 0;
  state.lag.n++; state.lag.sum += lag; state.lag.max = Math.max(state.lag.max, lag);
  if (document.hidden) state.heldAck = frame;
  else send({ type: 'ack', frame });
}

document.addEventListener('visibilitychange', () => {
  if (!document.hidden && state.heldAck !== null) {
    send({ type: 'ack', frame: state.heldAck });
    state.heldAck = null;
  }
});

// ---- figures ---------------------------------------------------------------------------------
function onStatus(s) {
  const prev = state.status;
  state.status = s;
  if (!prev || prev.epoch !== s.epoch) state.epochs.push({ epoch: s.epoch, frame: s.frame, mode: s.mode });
  state.modes.push({ frame: s.frame, mode: s.mode, complete: s.setsArrived === s.M * s.M, passes: s.passes, photonsPerSet: s.photonsPerSet });
  if (state.modes.length > 1000) state.modes.shift();
  $('frame').textContent = s.frame;
  $('fps').textContent = s.fps.toFixed(2);
  $('mode').textContent = (s.paused ? 'paused · ' : '') + s.mode;
  $('epoch').textContent = s.epoch;
  $('photons').textContent = Math.round(s.photonsPerSet).toLocaleString('en');
  $('pause').textContent = s.paused ? 'resume' : 'pause';
  // The estimator's progress: progressive passes since the view or scene last changed (each pass
  // adds photons to every pixel's estimate: the caustic converges while nothing moves), the
  // batches per pass (they grow while the view is still) and the caustic's estimated relative
  // error; or for knn how full the photon maps are against the cap at which accumulation stops.
  const capped = s.cap > 0 ? `${(100 * Math.min(1, s.photonsPerSet / s.cap)).toFixed(1)} % of the ${s.cap.toLocaleString('en')} photons/set cap` : '';
  $('progress').textContent = s.estimator === 'progressive'
    ? `estimator progressive: ${s.passes} pass${s.passes === 1 ? '' : 'es'} since the last change${s.mode === 'converging' ? `, converging (${s.passBatches} batch${s.passBatches === 1 ? '' : 'es'} a pass)` : ''}` +
      (s.errorEstimate > 0 ? ` · estimated caustic error ${(100 * s.errorEstimate).toFixed(1)} %` : '')
    : `estimator ${s.estimator || 'knn'}: ${capped}`;
  if (!drag) state.camera = { eye: s.camera.eye, forward: s.camera.forward, up: s.camera.up, yfov: s.camera.yfov };
  state.chart.push(s.split);
  if (state.chart.length > 120) state.chart.shift();
  drawChart();
  drawClients(s);
}

function drawChart() {
  const c = $('chart'), g = c.getContext('2d');
  g.clearRect(0, 0, c.width, c.height);
  const keys = ['photonMs', 'renderMs', 'encodeMs', 'masterMs'], colours = ['#e0a030', '#4aa0e0', '#9060d0', '#50c070'];
  const total = (d) => keys.reduce((a, k) => a + d[k], 0);
  const max = Math.max(1, ...state.chart.map(total));
  const w = c.width / 120;
  state.chart.forEach((d, i) => {
    let y = c.height;
    keys.forEach((k, j) => {
      const h = (d[k] / max) * (c.height - 14);
      g.fillStyle = colours[j];
      g.fillRect(i * w, y - h, Math.max(1, w - 1), h);
      y -= h;
    });
  });
  g.fillStyle = '#aab2bf';
  g.fillText(`${max.toFixed(0)} ms`, 4, 10);
}

function drawClients(s) {
  const body = $('clients').querySelector('tbody');
  body.replaceChildren(...s.clients.map((c) => {
    const tr = document.createElement('tr');
    const sw = document.createElement('span');
    sw.className = 'swatch';
    sw.style.background = ownerColour(c.id);
    const cells = [sw, c.name, String(c.cores), c.sets.join(' '), `${c.lastMs.toFixed(1)} ms`];
    for (const v of cells) {
      const td = document.createElement('td');
      if (typeof v === 'string') td.textContent = v; else td.appendChild(v);
      tr.appendChild(td);
    }
    return tr;
  }));
  const grid = $('grid');
  const m = s.M;
  grid.style.gridTemplateColumns = `repeat(${m}, 1fr)`;
  if (grid.children.length !== m * m) grid.replaceChildren(...Array.from({ length: m * m }, () => document.createElement('div')));
  s.owners.forEach((o, i) => {
    const d = grid.children[i];
    if (!d) return;
    d.style.background = ownerColour(o);
    d.textContent = o || '';
    d.title = `set ${i}: ${o ? 'client ' + o : 'nobody (previous values)'}`;
  });
}

function onEvent(e) {
  state.events.push(e);
  const li = document.createElement('li');
  li.textContent = `${new Date().toLocaleTimeString()} client ${e.id} (${e.name}) ${e.what}` +
    (e.cores ? `, ${e.cores} cores` : '') + (e.why ? `: ${e.why}` : '');
  $('events').prepend(li);
}

// ---- scene controls --------------------------------------------------------------------------
function onScene(s) {
  const first = !state.scene;
  const exposureBefore = first ? 0 : state.scene.settings.exposure;
  state.scene = s;
  if (s.settings.exposure !== exposureBefore) sendDisplay();
  $('scene-name').textContent = `${s.name} ${s.width}×${s.height}`;
  fillSelect($('light-index'), lightItems().map((l) => l.label));
  fillSelect($('material-index'), s.materials.map((m) => `material ${m.index} (${m.type})`));
  showLight();
  showMaterial();
  if (first) buildSettingsForm(s.knobs);
  if (first || !document.activeElement || !document.activeElement.id.startsWith('set-')) {
    for (const f of s.knobs) $(`set-${f.key}`).value = s.settings[f.key];
  }
}

// One field per live knob, as the master's knob table describes it (name, limits or choices,
// what a change resets).
function buildSettingsForm(knobs) {
  const box = $('settings-fields');
  box.textContent = '';
  for (const f of knobs) {
    const label = document.createElement('label');
    label.title = `${f.name}${f.unit ? ` (${f.unit})` : ''}; a change resets: ${f.resets}`;
    label.append(`${f.key} `);
    let input;
    if (f.choices) {
      input = document.createElement('select');
      for (const c of f.choices) input.append(new Option(c, c));
    } else {
      input = document.createElement('input');
      input.type = 'number';
      input.min = f.min; input.max = f.max; input.step = f.step;
    }
    input.id = `set-${f.key}`;
    label.append(input);
    box.append(label, ' ');
  }
}

function fillSelect(sel, labels) {
  const keep = sel.selectedIndex;
  if (sel.options.length !== labels.length) {
    sel.replaceChildren(...labels.map((l, i) => { const o = document.createElement('option'); o.value = i; o.textContent = l; return o; }));
    sel.selectedIndex = keep >= 0 && keep < labels.length ? keep : 0;
  }
}

// Punctual lights (light edits) and emissive objects (moved by transform edits from their loaded
// pose, intensity = their material's emission): one list, as a person thinks of "the light".
function lightItems() {
  const s = state.scene;
  if (!s) return [];
  return s.lights.map((l) => ({ kind: 'light', index: l.index, label: `light ${l.index}`, position: l.position, intensity: l.intensity }))
    .concat(s.emitters.map((e) => ({ kind: 'emitter', index: e.index, material: e.material, label: `emitter ${e.name || e.index}`,
      position: e.centre, loadedCentre: e.loadedCentre, intensity: e.emission })));
}

function showLight() {
  const s = state.scene, i = Number($('light-index').value || 0), l = lightItems()[i];
  const box = $('light-pos');
  if (!l) { box.textContent = 'no punctual light'; return; }
  if (box.dataset.light !== String(i) || !box.children.length) {
    box.dataset.light = String(i);
    box.replaceChildren(...['x', 'y', 'z'].map((axis, a) => {
      const row = document.createElement('div');
      row.className = 'pos-row';
      const r = document.createElement('input'), n = document.createElement('input');
      r.type = 'range'; n.type = 'number'; n.step = 'any';
      r.min = s.centre[a] - s.diagonal; r.max = s.centre[a] + s.diagonal; r.step = s.diagonal / 500;
      r.id = `light-${axis}`; n.id = `light-${axis}-n`;
      r.oninput = () => { n.value = Number(r.value).toFixed(4); sendLight(); };
      n.onchange = () => { r.value = n.value; sendLight(); };
      row.append(`${axis} `, r, ' ', n);
      return row;
    }));
  }
  ['x', 'y', 'z'].forEach((axis, a) => {
    const r = $(`light-${axis}`), n = $(`light-${axis}-n`);
    if (document.activeElement !== r && document.activeElement !== n) { r.value = l.position[a]; n.value = l.position[a].toFixed(4); }
  });
  if (document.activeElement !== $('light-intensity')) $('light-intensity').value = Math.max(...l.intensity);
}

let lightTimer = null;
function sendLight() {  // at most ~30 light edits per second while a slider is dragged
  if (lightTimer) return;
  lightTimer = setTimeout(() => {
    lightTimer = null;
    const position = ['x', 'y', 'z'].map((a) => Number($(`light-${a}-n`).value));
    const l = lightItems()[Number($('light-index').value)];
    if (!l) return;
    if (l.kind === 'light') send({ type: 'light', index: l.index, position });
    else send({ type: 'transform', index: l.index, translate: sub(position, l.loadedCentre) });
  }, 33);
}

function showMaterial() {
  const s = state.scene, m = s && s.materials[Number($('material-index').value || 0)];
  if (!m) return;
  $('material-type').textContent = m.type;
  $('material-ior').value = m.ior;
  $('material-color').value = '#' + m.color.map((c) => Math.round(Math.pow(Math.min(1, c), 1 / 2.2) * 255).toString(16).padStart(2, '0')).join('');
  $('material-absorption').value = Math.max(...m.absorption);
}

function colourOf(input) {
  const hex = input.value.slice(1);
  return [0, 2, 4].map((i) => Math.pow(parseInt(hex.slice(i, i + 2), 16) / 255, 2.2));
}

// ---- camera: orbit, pan, zoom ----------------------------------------------------------------
let drag = null;

function pivotOf(cam) {
  const s = state.scene;
  const d = s ? Math.max(0.05 * s.diagonal, dot(sub(s.centre, cam.eye), cam.forward)) : 1;
  return { pivot: add(cam.eye, mul(cam.forward, d)), dist: d };
}

let cameraPending = null;
function sendCamera(eye, target) {
  state.camera = { ...state.camera, eye, forward: norm(sub(target, eye)) };
  cameraPending = { type: 'camera', eye, target };
  if (sendCamera.timer) return;
  sendCamera.timer = setTimeout(() => { sendCamera.timer = null; send(cameraPending); }, 33);
}

function setupCamera() {
  const c = $('frame-canvas');
  c.addEventListener('contextmenu', (e) => e.preventDefault());
  c.addEventListener('mousedown', (e) => {
    if (!state.camera || !state.control) return;
    const { pivot, dist } = pivotOf(state.camera);
    drag = { x: e.clientX, y: e.clientY, pan: e.shiftKey || e.button === 2, cam: { ...state.camera }, pivot, dist };
    c.style.cursor = 'grabbing';
  });
  window.addEventListener('mouseup', () => { drag = null; c.style.cursor = 'grab'; });
  window.addEventListener('mousemove', (e) => {
    if (!drag) return;
    const dx = e.clientX - drag.x, dy = e.clientY - drag.y, cam = drag.cam;
    const right = norm(cross(cam.forward, [0, 1, 0]));
    if (drag.pan) {
      const up = norm(cross(right, cam.forward));
      const s = 2 * drag.dist * Math.tan(cam.yfov / 2) / c.clientHeight;
      const shift = add(mul(right, -dx * s), mul(up, dy * s));
      sendCamera(add(cam.eye, shift), add(drag.pivot, shift));
    } else {
      let v = sub(cam.eye, drag.pivot);
      v = rotate(v, [0, 1, 0], -dx * 0.01);
      const r2 = norm(cross(mul(v, -1), [0, 1, 0]));
      const pitched = rotate(v, r2, -dy * 0.01);
      if (Math.abs(norm(pitched)[1]) < 0.97) v = pitched;  // stay off the poles (up is +Y)
      sendCamera(add(drag.pivot, v), drag.pivot);
    }
  });
  c.addEventListener('wheel', (e) => {
    e.preventDefault();
    if (!state.camera || !state.control) return;
    const cam = state.camera, { pivot } = pivotOf(cam);
    const f = Math.pow(1.1, Math.sign(e.deltaY));
    sendCamera(add(pivot, mul(sub(cam.eye, pivot), f)), pivot);
  }, { passive: false });
}

// ---- other controls --------------------------------------------------------------------------
// The frames this page receives: the page's own exposure on top of the master's exposure knob
// (the PNG's), within the [-20, 20] stops a display control may ask for.
function sendDisplay() {
  const ev = Number($('exposure').value);
  const knob = state.scene ? Number(state.scene.settings.exposure) || 0 : 0;
  $('exposure-value').textContent = ev;
  send({ type: 'display', layer: $('layer').value, exposure: Math.max(-20, Math.min(20, ev + knob)) });
}

function saveScript(text) {
  state.lastScript = text;
  const a = document.createElement('a');
  a.href = URL.createObjectURL(new Blob([text], { type: 'text/plain' }));
  a.download = `${(state.scene && state.scene.name || 'rtpm').toLowerCase()}-session.rtpm-edits`;
  a.click();
  setTimeout(() => URL.revokeObjectURL(a.href), 1000);
}

function setup() {
  setupCamera();
  $('layer').onchange = sendDisplay;
  $('exposure').oninput = sendDisplay;
  $('pause').onclick = () => send({ type: 'pause', paused: !(state.status && state.status.paused) });
  $('snapshot').onclick = () => send({ type: 'snapshot' });
  $('script').onclick = () => send({ type: 'script' });
  $('light-index').onchange = () => { $('light-pos').dataset.light = ''; showLight(); };
  $('light-intensity').onchange = () => {
    const v = Number($('light-intensity').value);
    const l = lightItems()[Number($('light-index').value)];
    if (!l) return;
    if (l.kind === 'light') send({ type: 'light', index: l.index, intensity: [v, v, v] });
    else send({ type: 'material', index: l.material, emission: [v, v, v] });
  };
  $('material-index').onchange = showMaterial;
  $('material-apply').onclick = () => {
    const a = Number($('material-absorption').value);
    send({ type: 'material', index: Number($('material-index').value), ior: Number($('material-ior').value),
           color: colourOf($('material-color')), absorption: [a, a, a] });
  };
  $('settings-apply').onclick = () => {
    if (!state.scene) return;
    const s = state.scene.settings, msg = { type: 'settings' };
    for (const f of state.scene.knobs) {
      const raw = $(`set-${f.key}`).value, v = f.choices ? raw : Number(raw);
      if (v !== s[f.key]) msg[f.key] = v;
    }
    send(msg);
  };
  $('token-form').onsubmit = (e) => {
    e.preventDefault();
    sessionStorage.setItem('rtpm-token', $('token').value);
    location.hash = '';
    if (state.ws) state.ws.close();
    connect();
  };
  connect();
}

setup();
