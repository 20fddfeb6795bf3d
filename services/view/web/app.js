// tandem view's page. A Foxglove WebSocket protocol client (foxglove.websocket.v1): it subscribes to the viewer's
// JSON channels tandem/view/state, tandem/view/plot and tandem/view/events, and draws them with uPlot.
'use strict';

const WINDOW_S = 30;          // seconds of plot kept on screen
const MAX_EVENTS = 300;       // event rows kept
const plots = new Map();      // arm -> {u, data: [t[], ep[], hn[], hsg[]], hsg}
const channels = new Map();   // topic -> channel id
const subs = new Map();       // subscription id -> topic
let hSgOf = new Map();        // module -> h_sg
let received = {state: 0, plot: 0, events: 0};
window.tandemView = {received, plots: () => plots.size, points: () => [...plots.values()].map(p => p.data[0].length)};

const decoder = new TextDecoder();
let live = false;             // a running deployment (commands allowed), not a recording
const token = new URLSearchParams(location.search).get('token') || '';

// A live command (POST /api/command), as the CLI would run it; the viewer's answer goes in the header.
async function command(body, confirmText) {
  if (confirmText && !window.confirm(confirmText)) return;
  const answer = document.getElementById('answer');
  answer.textContent = `${body.command} ${body.target || ''}: sent`;
  try {
    const headers = {'Content-Type': 'application/json'};
    if (token) headers['X-Tandem-Token'] = token;
    const r = await fetch('/api/command', {method: 'POST', headers, body: JSON.stringify(body)});
    const a = await r.json();
    answer.textContent = `${body.command} ${body.target || ''}: ${a.text}`;
    answer.className = a.ok ? 'ok' : 'bad';
  } catch (e) {
    answer.textContent = `${body.command}: no answer (${e})`;
    answer.className = 'bad';
  }
}

function button(td, label, body, confirmText) {
  const b = document.createElement('button');
  b.textContent = label;
  b.onclick = () => command(body, confirmText);
  td.appendChild(b);
}

function connect() {
  const ws = new WebSocket(`ws://${location.host}/`, ['foxglove.websocket.v1']);
  ws.binaryType = 'arraybuffer';
  const conn = document.getElementById('conn');
  ws.onopen = () => { conn.textContent = 'connected'; conn.className = 'ok'; };
  live = true;
  document.getElementById('down').hidden = false;
  ws.onclose = () => {
    conn.textContent = 'disconnected; retrying'; conn.className = 'bad';
    // A new connection is a new session: its subscriptions, and the history it replays, start afresh.
    subs.clear();
    document.getElementById('events').replaceChildren();
    setTimeout(connect, 1000);
  };
  ws.onmessage = (ev) => {
    if (typeof ev.data === 'string') return onText(ws, JSON.parse(ev.data));
    const view = new DataView(ev.data);
    if (view.getUint8(0) !== 1) return;  // 2: time
    const sub = view.getUint32(1, true);
    const topic = subs.get(sub);
    const body = JSON.parse(decoder.decode(new Uint8Array(ev.data, 13)));
    if (topic === 'tandem/view/state') { received.state++; showState(body); }
    else if (topic === 'tandem/view/plot') { received.plot++; addPoints(body.points); }
    else if (topic === 'tandem/view/events') { received.events++; addEvent(body); }
  };
}

function onText(ws, msg) {
  if (msg.op === 'serverInfo') {
    document.getElementById('title').textContent = msg.name;
    document.title = msg.name;
  } else if (msg.op === 'advertise') {
    const wanted = ['tandem/view/state', 'tandem/view/plot', 'tandem/view/events'];
    const list = [];
    for (const c of msg.channels) {
      channels.set(c.topic, c.id);
      if (wanted.includes(c.topic)) {
        const id = subs.size + 1;
        subs.set(id, c.topic);
        list.push({id, channelId: c.id});
      }
    }
    ws.send(JSON.stringify({op: 'subscribe', subscriptions: list}));
  } else if (msg.op === 'status') {
    console.info('viewer:', msg.message);
  }
}

function cell(row, text, cls) {
  const td = row.insertCell();
  td.textContent = text === undefined || text === null ? '' : String(text);
  if (cls) td.className = cls;
  return td;
}

function showState(s) {
  const procs = document.querySelector('#procs tbody');
  procs.replaceChildren();
  for (const p of s.processes) {
    const r = procs.insertRow();
    cell(r, p.id);
    const act = cell(r, '', 'act');
    cell(r, p.role); cell(r, p.state, p.state);
    cell(r, p.serving || (p.role === 'robot' ? `strength ${p.strength}` : ''));
    cell(r, p.pid); cell(r, p.host); cell(r, p.detail);
    if (live && ['world', 'robot', 'supervisor', 'coordinator'].includes(p.role) && p.state === 'active') {
      button(act, 'kill', {command: 'kill', target: p.id}, `SIGKILL ${p.id}? (fault injection: its standby or restart takes over)`);
      if (p.role === 'robot') button(act, 'unplug', {command: 'unplug', kind: 'robot', target: p.id});
    }
  }
  const mods = document.querySelector('#mods tbody');
  mods.replaceChildren();
  hSgOf = new Map(s.modules.map(m => [m.name, m.h_sg]));
  for (const m of s.modules) {
    const r = mods.insertRow();
    cell(r, m.name);
    cell(r, m.task ? `#${m.task.id} ${m.task.state}` : '');
    cell(r, m.task ? m.task.done : '');
    const margin = m.grasp_margin;
    cell(r, margin === null ? '' : `${margin.toFixed(2)} N`, margin !== null && margin < 0 ? 'bad' : 'ok');
    cell(r, m.owners.map(o => `${o.arm}: ${o.state === 'served' ? o.robot : o.state}`).join(', '));
    const flags = [];
    if (m.failed) flags.push(`FAILED: ${m.failure}`);
    if (m.load_paused) flags.push('paused for load');
    if (m.braked.some(b => b)) flags.push('braked');
    cell(r, flags.join(', ') || 'running', flags.length ? 'bad' : 'ok');
    const act = cell(r, '', 'act');
    if (live) button(act, 'unplug', {command: 'unplug', kind: 'module', target: m.name}, `Unplug module ${m.name}? (it finishes its task first)`);
  }
  const drops = Object.entries(s.drops || {}).filter(([, n]) => n > 0);
  document.getElementById('drops').textContent =
      drops.length ? 'dropped for slow clients: ' + drops.map(([t, n]) => `${t} ${n}`).join(', ') : '';
}

function plotFor(arm) {
  let p = plots.get(arm);
  if (p) return p;
  if (typeof uPlot === 'undefined') {  // the build could not fetch it (no npm): tables and events only
    document.getElementById('plots').textContent =
        'Plots unavailable: uPlot was not fetched when tandem was built (it needs npm and the npm registry).';
    p = {u: {setData() {}}, data: [[], [], [], []]};
    plots.set(arm, p);
    return p;
  }
  const div = document.createElement('div');
  document.getElementById('plots').appendChild(div);
  const data = [[], [], [], []];
  const u = new uPlot({
    title: arm, width: 560, height: 220,
    scales: {x: {time: true}, ep: {auto: true}, hn: {auto: true}},
    series: [
      {},
      {label: '|e_p| [mm]', stroke: '#1f77b4', scale: 'ep'},
      {label: 'h_n [N]', stroke: '#d62728', scale: 'hn'},
      {label: 'h_sg [N]', stroke: '#7f7f7f', dash: [6, 4], scale: 'hn'},
    ],
    axes: [{}, {scale: 'ep', label: 'mm', size: 70, values: (u, vals) => tickLabels(vals)},
           {scale: 'hn', side: 1, label: 'N', grid: {show: false}}],
  }, data, div);
  p = {u, data};
  plots.set(arm, p);
  return p;
}

// Axis labels with as many digits as the tick spacing needs: a tracking error of 0.01529-0.01531 mm must not read
// 0.0153 on every tick (3 significant digits did). Exponent form below 1e-3 (nanometre errors are common).
function tickLabels(vals) {
  const step = vals.length > 1 ? Math.abs(vals[1] - vals[0]) : 0;
  const big = Math.max(...vals.map(v => Math.abs(v)));
  return vals.map(v => {
    if (v === 0 || !(step > 0)) return String(v);
    if (big < 1e-3 || big >= 1e5) return v.toExponential(Math.min(6, Math.max(1, Math.ceil(Math.log10(big / step)))));
    return v.toFixed(Math.min(8, Math.max(0, Math.ceil(-Math.log10(step)))));
  });
}

function addPoints(points) {
  const touched = new Set();
  for (const pt of points) {
    const p = plotFor(pt.arm);
    const hsg = hSgOf.get(pt.arm.split('/')[0]) ?? null;
    p.data[0].push(pt.t); p.data[1].push(pt.ep === null ? null : pt.ep * 1e3);
    p.data[2].push(pt.hn); p.data[3].push(hsg);
    touched.add(p);
  }
  for (const p of touched) {
    const last = p.data[0][p.data[0].length - 1];
    let cut = 0;
    while (cut < p.data[0].length && p.data[0][cut] < last - WINDOW_S) cut++;
    if (cut > 0) for (const s of p.data) s.splice(0, cut);
    p.u.setData(p.data);
  }
}

function addEvent(e) {
  const box = document.getElementById('events');
  const row = document.createElement('div');
  const when = new Date(e.t * 1000).toLocaleTimeString();
  const kind = document.createElement('span');
  kind.className = 'kind';
  kind.textContent = e.kind;
  row.append(`${when} `, kind, ` ${e.subject} ${e.detail}`);
  box.prepend(row);
  while (box.childElementCount > MAX_EVENTS) box.lastElementChild.remove();
}

// A recording (tandem view run.mcap): the same tables, plots and events at the slider's time, over HTTP.
async function replay(rec) {
  const slider = document.getElementById('slider');
  document.getElementById('replay').hidden = false;
  document.getElementById('conn').textContent = `recording, ${(rec.end - rec.start).toFixed(1)} s`;
  slider.min = rec.start; slider.max = rec.end; slider.value = rec.end;
  let busy = false, again = false;
  const show = async () => {
    if (busy) { again = true; return; }
    busy = true;
    const t = Number(slider.value);
    document.getElementById('clock').textContent = `${(t - rec.start).toFixed(1)} s of ${(rec.end - rec.start).toFixed(1)} s`;
    let at;
    try {
      at = await (await fetch(`/recording/at?t=${t}`)).json();
    } catch (e) {
      busy = false;
      document.getElementById('clock').textContent = `cannot read the recording at ${t}: ${e}`;
      return;
    }
    if (at.state && at.state.processes) showState(at.state);
    for (const p of plots.values()) {
      for (const s of p.data) s.length = 0;
      p.u.setData(p.data);
    }
    addPoints(at.points);
    document.getElementById('events').replaceChildren();
    for (const e of at.events) addEvent(e);
    received.state++; received.plot++;
    busy = false;
    if (again) { again = false; show(); }
  };
  slider.addEventListener('input', show);
  await show();
}

document.getElementById('down').onclick = () => command({command: 'down'}, 'Stop the whole deployment (tandem down)?');
fetch('/recording').then(r => (r.ok ? r.json() : null)).then(rec => (rec ? replay(rec) : connect()))
    .catch(() => connect());
