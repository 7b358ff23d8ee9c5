// The VES supervisors' pages (docs/web.md). Data is only ever put in the
// page as text (textContent), never parsed as HTML.
'use strict';

const ves = {charts: {}};
window.ves = ves;

function $(id) { return document.getElementById(id); }

function el(tag, text, attrs) {
  const e = document.createElement(tag);
  if (text !== undefined && text !== null) e.textContent = String(text);
  for (const [k, v] of Object.entries(attrs || {})) e.setAttribute(k, v);
  return e;
}

function row(cells) {
  const tr = document.createElement('tr');
  for (const c of cells) {
    const td = document.createElement('td');
    if (c instanceof Node) td.appendChild(c); else td.textContent = c === undefined ? '' : String(c);
    tr.appendChild(td);
  }
  return tr;
}

function link(text, href) { return el('a', text, {href: href}); }

function when(ms) {
  const n = Number(ms);
  return n > 0 ? new Date(n).toISOString().replace('T', ' ').slice(0, 19) + ' UTC' : '—';
}

function showError(message) {
  const p = $('error');
  p.textContent = message;
  p.hidden = false;
}

async function api(path, options) {
  const opts = Object.assign({credentials: 'same-origin', headers: {}}, options || {});
  if (opts.method === 'POST') {
    opts.headers['Content-Type'] = 'application/json';
    const csrf = sessionStorage.getItem('ves_csrf');
    if (csrf) opts.headers['X-CSRF-Token'] = csrf;
  }
  const res = await fetch('/api/v1/' + path, opts);
  let body = null;
  try { body = await res.json(); } catch (e) { body = null; }
  if (res.status === 401 && document.body.dataset.page !== 'sign-in') {
    location.href = '/index.html';
    throw new Error('not signed in');
  }
  if (!res.ok) {
    const message = body && body.error ? body.error.code + ': ' + body.error.message
                                       : 'HTTP ' + res.status;
    const error = new Error(message);
    error.status = res.status;
    error.detail = body && body.error ? body.error.message : '';
    throw error;
  }
  return body;
}

function param(name) { return new URLSearchParams(location.search).get(name) || ''; }

async function signedIn() {
  const me = await api('me');
  ves.me = me;  // the workflow's forms show by role (workflow.js)
  if (me.csrf_token) sessionStorage.setItem('ves_csrf', me.csrf_token);
  $('nav').hidden = false;
  $('who').textContent = me.label + ' (' + me.role + ', ' + me.institution + ')';
  $('nav-audit').hidden = me.role !== 'admin';
  $('sign-out').addEventListener('click', async () => {
    try {
      await api('sign-out', {method: 'POST', body: '{}'});
    } finally {
      sessionStorage.removeItem('ves_csrf');
      location.href = '/index.html';
    }
  });
  return me;
}

// ---- pages --------------------------------------------------------------

// Why a sign-in through the identity provider came back refused
// (/index.html?error=CODE, set by the server's callback).
const kSignInErrors = {
  idp: 'The hospital sign-in did not complete. Try again.',
  no_account: 'Your hospital account is not linked to a VES account. Ask a VES administrator.',
  account: 'Your VES account is revoked or has expired. Ask a VES administrator.',
  unavailable: 'The hospital sign-in is not reachable now. Try again later.',
  busy: 'Too many people are signed in. Try again later.',
};

async function signInPage() {
  const error = param('error');
  if (error) showError(kSignInErrors[error] || 'Sign-in refused.');
  const finish = (reply) => {
    sessionStorage.setItem('ves_csrf', reply.csrf_token);
    location.href = '/trainees.html';
  };
  $('password-form').addEventListener('submit', async (event) => {
    event.preventDefault();
    try {
      finish(await api('sign-in', {method: 'POST', body: JSON.stringify(
          {username: $('username').value.trim().toLowerCase(), password: $('password').value})}));
    } catch (e) {
      $('password').value = '';
      showError(e.message);
    }
  });
  $('sign-in-form').addEventListener('submit', async (event) => {
    event.preventDefault();
    try {
      finish(await api('sign-in', {method: 'POST',
                                   body: JSON.stringify({token: $('token').value})}));
    } catch (e) {
      showError(e.message);
    }
  });
  try {
    const methods = await api('sign-in');
    $('oidc').hidden = !methods.oidc;
  } catch (e) {
    // The sign-in page works without knowing: the forms stay.
  }
}

async function traineesPage() {
  const me = await signedIn();
  $('institution').textContent = me.institution;
  const body = $('trainees').querySelector('tbody');
  let token = '';
  const groups = new Set();
  do {
    const page = await api('trainees?page_size=500' +
                           (token ? '&page_token=' + encodeURIComponent(token) : ''));
    for (const t of page.trainees) {
      body.appendChild(row([
        link(t.trainee_id, '/trainee.html?id=' + encodeURIComponent(t.trainee_id)),
        t.display_name,
        t.group ? link(t.group, '/group.html?group=' + encodeURIComponent(t.group)) : '—',
        t.sessions, when(t.last_activity_unix_ms), curriculaCell(t.curricula)]));
      if (t.group) groups.add(t.group);
    }
    token = page.next_page_token;
  } while (token);
  for (const g of [...groups].sort()) {
    const li = el('li');
    li.appendChild(link(g, '/group.html?group=' + encodeURIComponent(g)));
    li.appendChild(document.createTextNode(' · '));
    li.appendChild(link('lesson progress', '/progress.html?group=' + encodeURIComponent(g)));
    $('groups').appendChild(li);
  }
}

function lineChart(canvas, title, yLabel, datasets) {
  return new Chart(canvas, {
    type: 'line',
    data: {datasets: datasets},
    options: {
      animation: false, responsive: true, maintainAspectRatio: false, parsing: false,
      plugins: {title: {display: true, text: title},
                // The expert band's lower edge is drawn, not named.
                legend: {display: datasets.length > 1,
                         labels: {filter: (item) => item.text !== 'expert low'}}},
      scales: {x: {type: 'linear', title: {display: true, text: 'attempt'}, ticks: {precision: 0}},
               y: {title: {display: true, text: yLabel}, beginAtZero: true}}
    }
  });
}

// OUTCOME_CECUM_REACHED -> "cecum reached" (the enum name as words).
function outcomeText(outcome) {
  return String(outcome || '').replace(/^OUTCOME_/, '').toLowerCase().replace(/_/g, ' ');
}

// `band`: the scripted expert's runs of the case (docs/web.md, "Proficiency").
function curveBlock(container, kind, name, points, median, pass, band) {
  const block = el('section', null, {class: 'curve', id: 'curve-' + kind + '-' + name});
  block.appendChild(el('h3', (kind === 'case' ? 'Case ' : 'Lesson ') + name));
  const metrics = [['score', 'Score', '/100'], ['time_to_cecum_s', 'Time to cecum', 's'],
                   ['pain_s', 'Pain', 's'], ['loop_s', 'Loop time', 's']];
  const charts = [];
  for (const [key, title, unit] of metrics) {
    const div = el('div', null, {class: 'plot'});
    const canvas = el('canvas', null, {'data-metric': key});
    div.appendChild(canvas);
    block.appendChild(div);
    const sets = [{label: title, data: points.map((p) => ({x: p.attempt, y: p[key]})),
                   borderColor: '#1f5fa8', backgroundColor: '#1f5fa8'}];
    if (key === 'score' && median && median.length) {
      sets.push({label: 'group median', data: median.map((m) => ({x: m.attempt, y: m.score})),
                 borderColor: '#999', borderDash: [6, 4], backgroundColor: '#999'});
    }
    if (pass && pass[key] !== undefined && points.length) {
      const last = points[points.length - 1].attempt;
      sets.push({label: 'pass line', data: [{x: 1, y: pass[key]}, {x: Math.max(last, 2), y: pass[key]}],
                 borderColor: '#2a2', pointRadius: 0, backgroundColor: '#2a2'});
    }
    if (band && band[key] && points.length) {
      const last = Math.max(points[points.length - 1].attempt, 2);
      const [lo, hi] = band[key];
      sets.push({label: 'expert low', data: [{x: 1, y: lo}, {x: last, y: lo}],
                 borderColor: 'rgba(220,120,0,0.7)', pointRadius: 0, borderWidth: 1});
      sets.push({label: 'expert band (' + band.runs + ' runs)', data: [{x: 1, y: hi}, {x: last, y: hi}],
                 borderColor: 'rgba(220,120,0,0.7)', pointRadius: 0, borderWidth: 1,
                 fill: '-1', backgroundColor: 'rgba(220,120,0,0.18)'});
    }
    container.appendChild(block);
    charts.push(lineChart(canvas, title, unit, sets));
  }
  // The same points as a table, for reading and for screen readers.
  const table = el('table', null, {class: 'points'});
  table.appendChild(el('thead')).appendChild(row(['Attempt', 'Score', 'Time to cecum (s)',
                                                  'Pain (s)', 'Loop (s)', 'Session']));
  const tbody = table.appendChild(el('tbody'));
  for (const p of points) {
    tbody.appendChild(row([p.attempt, p.score.toFixed(1),
                           p.time_to_cecum_s === null ? '—' : p.time_to_cecum_s.toFixed(1),
                           p.pain_s.toFixed(1), p.loop_s.toFixed(1),
                           link('open', '/session.html?uuid=' + encodeURIComponent(p.uuid))]));
  }
  block.appendChild(table);
  if (band) block.appendChild(el('p', expertBandText(band), {class: 'expert-band'}));
  ves.charts[kind + ':' + name] = charts;
}

async function traineePage() {
  await signedIn();
  const id = param('id');
  $('trainee-id').textContent = id;
  const curve = await api('trainees/' + encodeURIComponent(id) + '/curve');
  $('trainee-group').textContent = curve.group || '—';
  $('report-link').href = '/report.html?id=' + encodeURIComponent(id);
  for (const c of curve.cases) {
    curveBlock($('curves'), 'case', c.case_id, c.points, c.group_median, null, c.expert_band);
  }
  for (const l of curve.lessons) {
    curveBlock($('curves'), 'lesson', l.lesson_id, l.points, null, l.pass_line, l.expert_band);
  }
  // The CSV export of the sessions between the chosen days (docs/web.md, "Export").
  const exportLink = () => {
    let range = '';
    const from = utcDayMs($('export-from').value), to = utcDayMs($('export-to').value);
    if (!Number.isNaN(from)) range += '&from_unix_ms=' + from;
    if (!Number.isNaN(to)) range += '&to_unix_ms=' + (to + 24 * 3600 * 1000);
    $('export-csv').href = '/api/v1/trainees/' + encodeURIComponent(id) + '/sessions.csv' +
                           range.replace('&', '?');
  };
  for (const input of ['export-from', 'export-to']) $(input).addEventListener('change', exportLink);
  exportLink();
  const sessions = await api('trainees/' + encodeURIComponent(id) + '/sessions?page_size=500');
  const signOffs = await api('trainees/' + encodeURIComponent(id) + '/sign-offs');
  const signedOff = new Map(signOffs.sign_offs.map((o) => [o.session_uuid, o]));
  const body = $('sessions').querySelector('tbody');
  for (const s of sessions.sessions.slice().reverse()) {
    const so = signedOff.get(s.uuid);
    body.appendChild(row([link(when(s.start_unix_ms), '/session.html?uuid=' + encodeURIComponent(s.uuid)),
                          s.case_id, outcomeText(s.outcome), Number(s.score).toFixed(1),
                          s.completed ? Number(s.time_to_cecum_s).toFixed(1) + ' s' : '—',
                          so ? (so.signed_by_label || so.signed_by) + ', ' + when(so.signed_unix_ms) : '—']));
  }
}

// Shades the time spans where a frame flag (pain, loop) is set.
const bandsPlugin = {
  id: 'vesBands',
  beforeDatasetsDraw(chart, args, opts) {
    const frames = opts.frames;
    if (!frames || !frames.length) return;
    const {ctx, chartArea, scales} = chart;
    ctx.save();
    for (const [flag, color] of [['pain', 'rgba(220,0,0,0.18)'], ['loop', 'rgba(0,80,220,0.15)']]) {
      ctx.fillStyle = color;
      let start = null;
      for (let i = 0; i <= frames.length; i++) {
        const on = i < frames.length && frames[i][flag];
        if (on && start === null) start = frames[i].t_s;
        if (!on && start !== null) {
          const end = frames[Math.min(i, frames.length - 1)].t_s;
          const x0 = scales.x.getPixelForValue(start), x1 = scales.x.getPixelForValue(end);
          ctx.fillRect(x0, chartArea.top, Math.max(1, x1 - x0), chartArea.bottom - chartArea.top);
          start = null;
        }
      }
    }
    ctx.restore();
  }
};

// The replay's time on every plot (chart.$vesCursorT, seconds): a dashed line.
const cursorPlugin = {
  id: 'vesCursor',
  afterDatasetsDraw(chart) {
    const t = chart.$vesCursorT;
    if (typeof t !== 'number') return;
    const {ctx, chartArea, scales} = chart;
    const x = scales.x.getPixelForValue(t);
    if (x < chartArea.left - 1 || x > chartArea.right + 1) return;
    ctx.save();
    ctx.strokeStyle = '#222';
    ctx.lineWidth = 2;
    ctx.setLineDash([5, 3]);
    ctx.beginPath(); ctx.moveTo(x, chartArea.top); ctx.lineTo(x, chartArea.bottom); ctx.stroke();
    ctx.restore();
  }
};

function timeChart(canvas, title, frames, series, onPick) {
  return new Chart(canvas, {
    type: 'line',
    data: {datasets: series.map(([label, key, scale, color]) => ({
      label: label, data: frames.map((f) => ({x: f.t_s, y: f[key] * scale})),
      borderColor: color, backgroundColor: color, pointRadius: 0, borderWidth: 1.5}))},
    options: {
      animation: false, responsive: true, maintainAspectRatio: false, parsing: false,
      plugins: {title: {display: true, text: title}, vesBands: {frames: frames}},
      scales: {x: {type: 'linear', title: {display: true, text: 's'}}},
      onClick: onPick ? (event, elements, chart) => onPick(chart.scales.x.getValueForPixel(event.x)) : undefined
    },
    plugins: onPick ? [bandsPlugin, cursorPlugin] : [bandsPlugin]
  });
}

// As the fluoroscopy view: AP projection, image right = -x, up = +z; the
// box `b` (of every shape shown) fills the canvas.
function drawShape(canvas, shape, b) {
  const ctx = canvas.getContext('2d');
  ctx.fillStyle = '#8a8a8a';
  ctx.fillRect(0, 0, canvas.width, canvas.height);
  const scale = Math.min(canvas.width / (b.x1 - b.x0), canvas.height / (b.y1 - b.y0)) * 0.9;
  const px = (p) => [canvas.width / 2 + (p[0] - (b.x0 + b.x1) / 2) * scale,
                     canvas.height / 2 - (p[1] - (b.y0 + b.y1) / 2) * scale];
  const path = (points, width, color) => {
    ctx.beginPath();
    points.forEach((p, i) => { const [x, y] = px(p); if (i) ctx.lineTo(x, y); else ctx.moveTo(x, y); });
    ctx.lineWidth = width; ctx.strokeStyle = color; ctx.lineJoin = 'round'; ctx.lineCap = 'round';
    ctx.stroke();
  };
  if (shape && shape.scope_mm && shape.scope_mm.length) {
    path(shape.colon_mm || [], Math.max(4, 45 * scale), 'rgba(60,60,60,0.45)');
    path(shape.scope_mm, Math.max(2, 12 * scale), '#1a1a1a');
    const tip = px(shape.scope_mm[shape.scope_mm.length - 1]);
    ctx.fillStyle = '#ffd24a';
    ctx.beginPath(); ctx.arc(tip[0], tip[1], 4, 0, 2 * Math.PI); ctx.fill();
  }
}

function drawFrame(replay, index) {
  const frames = replay.frames;
  const f = frames[index];
  let shape = null;
  for (let i = index; i >= 0 && !shape; i--) if (frames[i].scope_mm) shape = frames[i];
  drawShape($('fluoro'), shape, replay.bounds);
  $('fig-t').textContent = f.t_s.toFixed(1) + ' s';
  $('tip-depth').textContent = (f.tip_arc_m * 1000).toFixed(0) + ' mm';
  $('fig-inserted').textContent = (f.inserted_m * 1000).toFixed(0) + ' mm';
  $('fig-force').textContent = f.hand_force_N.toFixed(2) + ' N';
  $('fig-stretch').textContent = (f.stretch_m * 1000).toFixed(1) + ' mm';
  $('fig-pain').textContent = f.pain ? 'yes' : 'no';
  $('fig-loop').textContent = f.loop ? 'yes' : 'no';
}

async function sessionPage() {
  await signedIn();
  const uuid = param('uuid');
  $('session-uuid').textContent = uuid;
  ves.timing = {};
  // Both at once: the series is the larger answer.
  const seriesPromise = loadSeries(uuid);
  seriesPromise.catch(() => {});  // reported where it is awaited
  const s = await api('sessions/' + encodeURIComponent(uuid));
  ves.timing.summary_ms = performance.now();
  const r = s.record, m = r.metrics || {};
  const summary = [['Trainee', r.trainee_id], ['Case', r.case_id + ' v' + r.case_version],
                   ['Lesson', r.lesson_id || '—'], ['Station', r.station_id],
                   ['Operator', r.operator_kind], ['Started', when(r.start_unix_ms)],
                   ['Outcome', outcomeText(r.outcome)], ['Score', Number(r.score).toFixed(1) + '/100'],
                   ['Time to cecum', m.completed ? Number(m.time_to_cecum_s).toFixed(1) + ' s' : '—'],
                   ['Pain', Number(m.pain_s || 0).toFixed(1) + ' s'],
                   ['Loop', Number(m.loop_s || 0).toFixed(1) + ' s'],
                   ['Abdominal pressure', 'left lower quadrant ' + Number(m.press_llq_s || 0).toFixed(1) +
                    ' s, mid-abdomen ' + Number(m.press_mid_s || 0).toFixed(1) + ' s'],
                   ['Patient position', (m.position_changes || 0) + ' changes; left lateral ' +
                    Number(m.left_lateral_s || 0).toFixed(1) + ' s, right lateral ' +
                    Number(m.right_lateral_s || 0).toFixed(1) + ' s'],
                   ['Deepest tip', (Number(m.max_tip_arc_m || 0) * 1000).toFixed(0) + ' mm']];
  for (const [k, v] of summary) { $('summary').appendChild(el('dt', k)); $('summary').appendChild(el('dd', v)); }
  // The station's health during this session, flagged as on the stations page.
  const health = s.station_health;
  const healthNames = ['Device', 'Loop p99 / budget', 'Loop overruns', 'Safe state', 'CAN errors'];
  const healthValues = healthTexts(health);
  const healthRows = [['Software', r.software_version || '—']];
  healthNames.forEach((name, i) => healthRows.push([name, healthValues[i]]));
  const healthDds = [];
  for (const [k, v] of healthRows) {
    $('health').appendChild(el('dt', k));
    healthDds.push($('health').appendChild(el('dd', v)));
  }
  for (const [flag, [index, title]] of Object.entries(healthFlagWhy)) {
    if (!s.station_health_flags.includes(flag)) continue;
    healthDds[1 + index].classList.add('flagged');
    healthDds[1 + index].setAttribute('title', title);
  }
  showVerdict(s.lesson_verdict);
  const series = await seriesPromise;
  const b = {x0: Infinity, x1: -Infinity, y0: Infinity, y1: -Infinity};
  for (const f of series.frames) {
    for (const p of (f.colon_mm || []).concat(f.scope_mm || [])) {
      b.x0 = Math.min(b.x0, p[0]); b.x1 = Math.max(b.x1, p[0]);
      b.y0 = Math.min(b.y0, p[1]); b.y1 = Math.max(b.y1, p[1]);
    }
  }
  if (!(b.x1 > b.x0)) { b.x0 = -200; b.x1 = 200; b.y0 = -200; b.y1 = 200; }
  series.bounds = b;
  ves.replay = series;
  $('replay-status').textContent = series.summary;
  $('replay-status').classList.remove('busy');
  $('replay').hidden = false;
  const frames = series.frames;
  const seek = (t) => showReplayAt(timeIndex(frames, t), t);
  ves.charts.force = timeChart($('plot-force'), 'Hand force (N)', frames,
                               [['hand force N', 'hand_force_N', 1, '#a33']], seek);
  ves.charts.stretch = timeChart($('plot-stretch'), 'Colon stretch (mm)', frames,
                                 [['stretch mm', 'stretch_m', 1000, '#a60']], seek);
  ves.charts.depth = timeChart($('plot-depth'), 'Tip depth and inserted length (mm)', frames,
                               [['tip depth mm', 'tip_arc_m', 1000, '#15a'],
                                ['inserted mm', 'inserted_m', 1000, '#5a5']], seek);
  ves.timing.plots_ms = performance.now();
  setupPlayer(series);
}

// The series of the session (docs/web.md, "Session series"); while the
// server is busy computing series (429) it says so and asks again by itself.
async function loadSeries(uuid) {
  for (let attempt = 1; ; attempt++) {
    ves.seriesAttempts = attempt;
    try {
      return await api('sessions/' + encodeURIComponent(uuid) + '/series');
    } catch (e) {
      if (e.status !== 429 || attempt >= 60) throw e;
      ves.seriesBusy = (ves.seriesBusy || 0) + 1;
      const wait = Math.min(5, attempt + 1);
      const status = $('replay-status');
      status.classList.add('busy');
      status.textContent = 'The server is busy (' + e.detail + '). Trying again in ' + wait +
                           ' s (attempt ' + attempt + ')…';
      await new Promise((resolve) => setTimeout(resolve, wait * 1000));
      status.textContent = 'Asking again for the session\'s plots…';
    }
  }
}

const verdictText = {passed: 'PASSED', failed: 'FAILED', rejected: 'REJECTED',
                     pending: 'Not judged yet', unknown: 'Verdict unavailable'};

// The server's verdict on a lesson session and each criterion's outcome.
function showVerdict(v) {
  if (!v) return;  // a free run
  $('verdict').hidden = false;
  const status = $('verdict-status');
  status.textContent = verdictText[v.status] || v.status;
  status.className = 'verdict ' + v.status;
  let note = 'lesson ' + v.lesson_id;
  if (v.judged_unix_ms) note += ', judged by the server ' + when(v.judged_unix_ms);
  if (v.status === 'pending') note += ': the server has not replayed it yet';
  $('verdict-note').textContent = note;
  for (const c of v.checks || []) {
    const outcome = c.passed === true ? 'passed' : c.passed === false ? 'failed' : 'note';
    const li = el('li', null, {class: outcome});
    li.appendChild(el('span', c.passed === true ? '✓ passed' : c.passed === false ? '✗ failed' : '•',
                      {class: 'mark'}));
    li.appendChild(document.createTextNode(' ' + c.text));
    $('verdict-checks').appendChild(li);
  }
}

// The last frame at or before t (frames ordered by t_s).
function timeIndex(frames, t) {
  let lo = 0, hi = frames.length - 1;
  while (lo < hi) {
    const mid = (lo + hi + 1) >> 1;
    if (frames[mid].t_s <= t) lo = mid; else hi = mid - 1;
  }
  return lo;
}

// The replay at frame `index`: view, figures, scrubber and the plots' cursor.
function showReplayAt(index, t) {
  const frames = ves.replay.frames;
  const player = ves.player;
  player.index = index;
  player.t = Math.max(frames[0].t_s, Math.min(t, frames[frames.length - 1].t_s));
  $('scrub').value = String(index);
  drawFrame(ves.replay, index);
  for (const chart of [ves.charts.force, ves.charts.stretch, ves.charts.depth]) {
    chart.$vesCursorT = player.t;
    chart.draw();
  }
}

function setupPlayer(series) {
  const frames = series.frames;
  const end = frames[frames.length - 1].t_s;
  const player = ves.player = {t: frames[0].t_s, index: 0, playing: false, speed: 1, timer: null};
  const button = $('play');
  const pause = () => {
    player.playing = false;
    clearInterval(player.timer);
    player.timer = null;
    button.textContent = 'Play';
  };
  const play = () => {
    if (player.t >= end) showReplayAt(0, frames[0].t_s);  // from the start again
    player.playing = true;
    button.textContent = 'Pause';
    let last = performance.now();
    player.timer = setInterval(() => {
      const now = performance.now();
      const t = player.t + (now - last) / 1000 * player.speed;
      last = now;
      showReplayAt(timeIndex(frames, t), Math.min(t, end));
      if (t >= end) pause();
    }, 50);
  };
  button.addEventListener('click', () => (player.playing ? pause() : play()));
  $('speed').addEventListener('change', () => { player.speed = Number($('speed').value); });
  player.speed = Number($('speed').value);
  const scrub = $('scrub');
  scrub.max = String(frames.length - 1);
  scrub.addEventListener('input', () => {
    const i = Number(scrub.value);
    showReplayAt(i, frames[i].t_s);
  });
  showReplayAt(0, frames[0].t_s);
}

async function progressPage() {
  await signedIn();
  const group = param('group');
  $('group-name').textContent = group;
  const progress = await api('groups/' + encodeURIComponent(group) + '/progress');
  const lessons = [];
  for (const t of progress.trainees) for (const l of t.lessons) if (!lessons.includes(l.lesson_id)) lessons.push(l.lesson_id);
  $('progress').querySelector('thead').appendChild(row(['Trainee', 'Next lesson'].concat(lessons)));
  const body = $('progress').querySelector('tbody');
  for (const t of progress.trainees) {
    const cells = [link(t.trainee_id, '/trainee.html?id=' + encodeURIComponent(t.trainee_id)),
                   t.next_lesson_id || '—'];
    for (const id of lessons) {
      const l = t.lessons.find((x) => x.lesson_id === id);
      cells.push(l ? (l.completed ? 'passed ' : '') + l.passes + '/' + l.required_passes +
                     ' (' + l.attempts + ' tried)' : '—');
    }
    const tr = row(cells);
    [...tr.children].slice(2).forEach((td) => { if (td.textContent.startsWith('passed')) td.className = 'passed'; });
    body.appendChild(tr);
  }
}

// A UTC day (YYYY-MM-DD, as a date input gives it) as Unix ms at its start;
// NaN when it is not one.
function utcDayMs(day) {
  const m = /^(\d{4})-(\d{2})-(\d{2})$/.exec(day);
  return m ? Date.UTC(Number(m[1]), Number(m[2]) - 1, Number(m[3])) : NaN;
}

// The audit log, newest first, a page at a time, filtered as the form (and
// the address: audit.html?actor=&action=&from=&to=) says.
async function auditPage() {
  await signedIn();
  const dayMs = 24 * 3600 * 1000;
  let filter = '';
  for (const [name, input] of [['actor', 'filter-actor'], ['action', 'filter-action']]) {
    const v = param(name);
    $(input).value = v;
    if (v) filter += '&' + name + '=' + encodeURIComponent(v);
  }
  for (const [name, input, key, extra] of [['from', 'filter-from', 'from_unix_ms', 0],
                                           ['to', 'filter-to', 'to_unix_ms', dayMs]]) {
    const v = param(name);
    if (!v) continue;
    const ms = utcDayMs(v);
    if (Number.isNaN(ms)) throw new Error(name + ' = \'' + v + '\': not a date (YYYY-MM-DD)');
    $(input).value = v;
    filter += '&' + key + '=' + (ms + extra);
  }
  const body = $('audit').querySelector('tbody');
  const tokens = [''];  // the token of each page seen; the last is the one shown
  let next = '';
  const show = async (token) => {
    const page = await api('audit?page_size=50' + filter +
                           (token ? '&page_token=' + encodeURIComponent(token) : ''));
    body.replaceChildren();
    for (const e of page.entries) {
      body.appendChild(row([e.id, when(e.at_unix_ms), e.actor_label || e.actor, e.role,
                            e.institution, e.action, e.target, e.result]));
    }
    next = page.next_page_token;
    $('audit-page').textContent = page.entries.length === 0 ? 'No entries.'
        : 'Page ' + tokens.length + ': entries ' + page.entries[0].id + ' to ' +
          page.entries[page.entries.length - 1].id + (next ? '' : ' (the oldest)');
    $('audit-older').disabled = !next;
    $('audit-newer').disabled = tokens.length < 2;
    $('audit').dataset.page = String(tokens.length);  // which page is shown (tests wait on it)
  };
  const go = (f) => f().catch((e) => showError(e.message));
  $('audit-older').addEventListener('click', () => go(async () => {
    tokens.push(next);
    await show(next);
  }));
  $('audit-newer').addEventListener('click', () => go(async () => {
    tokens.pop();
    await show(tokens[tokens.length - 1]);
  }));
  await show('');
}

// A station's health (the API's shape, docs/web.md) as the texts of its
// device, loop, overruns, safe-state and CAN figures; null: not reported.
function healthTexts(h) {
  if (!h) return ['not reported', '—', '—', '—', '—'];
  const loop = h.loop_cycle_p99_us === null
      ? 'not timed (simulated time) / ' + h.loop_budget_us.toFixed(0) + ' µs'
      : h.loop_cycle_p99_us.toFixed(0) + ' / ' + h.loop_budget_us.toFixed(0) + ' µs';
  const canTotal = h.can_bus_errors + h.can_lost_frames + h.can_send_failures +
                   h.can_malformed_frames;
  return [h.device, loop,
          h.loop_cycles > 0 ? h.loop_overruns + ' of ' + h.loop_cycles : '—',
          (h.safe_state_entries + h.force_pauses) + ' (' + h.safe_state_entries +
              ' re-armed, ' + h.force_pauses + ' paused)',
          canTotal + ' (bus ' + h.can_bus_errors + ', lost ' + h.can_lost_frames +
              ', unsent ' + h.can_send_failures + ', malformed ' + h.can_malformed_frames + ')'];
}
// The server's health flags: which of healthTexts' figures each marks, and why.
const healthFlagWhy = {loop_p99: [1, 'loop p99 over its budget'], overruns: [2, 'the loop overran'],
                       safe_state: [3, 'the device went to its safe state'],
                       can_errors: [4, 'CAN errors']};

// Stations: one row each, health figures as text; a flagged cell gets the
// class "flagged" and a title saying why (the server decides the flags).
async function stationsPage() {
  const me = await signedIn();
  $('institution').textContent = me.institution;
  const body = $('stations').querySelector('tbody');
  let token = '';
  do {
    const page = await api('stations?page_size=500' +
                           (token ? '&page_token=' + encodeURIComponent(token) : ''));
    for (const s of page.stations) {
      const h = s.health;
      const flags = new Set(s.flags);
      const cells = [s.station_id, when(s.last_seen_unix_ms), s.software_version || '—']
          .concat(healthTexts(h));
      const tr = row(cells);
      tr.dataset.station = s.station_id;
      for (const [flag, [index, title]] of Object.entries(healthFlagWhy)) {
        if (!flags.has(flag)) continue;
        const column = 3 + index;
        tr.children[column].classList.add('flagged');
        tr.children[column].setAttribute('title', title);
      }
      if (flags.size > 0) tr.classList.add('unhealthy');
      body.appendChild(tr);
    }
    token = page.next_page_token;
  } while (token);
  $('no-stations').hidden = body.children.length > 0;
}

// Live: the institution's running sessions; with ?session=UUID, that one's
// frames over a WebSocket (the server sends only the newest to a slow page).
async function livePage() {
  await signedIn();
  const uuid = param('session');
  const list = async () => {
    const live = (await api('live')).live;
    const body = $('live-list').querySelector('tbody');
    body.replaceChildren();
    for (const l of live) {
      body.appendChild(row([l.trainee_id, l.case_id + ' v' + l.case_version, l.station,
                            when(l.started_unix_ms), Number(l.t_s).toFixed(1) + ' s', l.frames,
                            link('watch', '/live.html?session=' + encodeURIComponent(l.session_uuid))]));
      if (l.session_uuid === uuid) $('live-who').textContent = l.trainee_id + ' on ' + l.case_id;
    }
    $('live-none').hidden = live.length > 0;
  };
  await list();
  setInterval(() => list().catch((e) => showError(e.message)), 2000);
  if (!uuid) return;
  $('live-view').hidden = false;
  const b = {x0: Infinity, x1: -Infinity, y0: Infinity, y1: -Infinity};
  ves.live = {frames: 0, tips: []};
  const scheme = location.protocol === 'https:' ? 'wss://' : 'ws://';
  const ws = new WebSocket(scheme + location.host + '/api/v1/live/ws?session=' + encodeURIComponent(uuid));
  await new Promise((resolve, reject) => {
    ws.onopen = () => { $('live-status').textContent = 'Live'; resolve(); };
    ws.onerror = () => reject(new Error('the live session ' + uuid + ' cannot be watched (ended, or not yours)'));
  });
  ws.onclose = () => { $('live-status').textContent = 'The session ended (or the connection closed).'; };
  ws.onmessage = (event) => {
    const f = JSON.parse(event.data);
    if (f.ended) { $('live-status').textContent = 'The session ended.'; return; }
    for (const p of (f.colon_mm || []).concat(f.scope_mm || [])) {
      b.x0 = Math.min(b.x0, p[0]); b.x1 = Math.max(b.x1, p[0]);
      b.y0 = Math.min(b.y0, p[1]); b.y1 = Math.max(b.y1, p[1]);
    }
    if (b.x1 > b.x0 && b.y1 > b.y0) drawShape($('live-fluoro'), f, b);
    ves.live.frames += 1;
    ves.live.tips.push(f.tip_arc_m);
    $('live-t').textContent = Number(f.t_s).toFixed(1) + ' s';
    $('live-tip-depth').textContent = (f.tip_arc_m * 1000).toFixed(0) + ' mm';
    $('live-inserted').textContent = (f.inserted_m * 1000).toFixed(0) + ' mm';
    $('live-force').textContent = Number(f.hand_force_N).toFixed(2) + ' N';
    $('live-stretch').textContent = (f.stretch_m * 1000).toFixed(1) + ' mm';
    $('live-pain').textContent = f.pain ? 'yes' : 'no';
    $('live-loop').textContent = f.loop ? 'yes' : 'no';
    $('live-frames').textContent = String(ves.live.frames);
    if (f.sent_unix_ms > 0) $('live-latency').textContent = (Date.now() - f.sent_unix_ms) + ' ms (station clock)';
    if (f.jpeg_base64) {
      $('live-jpeg').src = 'data:image/jpeg;base64,' + f.jpeg_base64;
      $('live-jpeg').hidden = false;
    }
  };
}

const pages = {'sign-in': signInPage, trainees: traineesPage, trainee: traineePage,
               session: sessionPage, progress: progressPage, audit: auditPage,
               live: livePage, stations: stationsPage};

document.addEventListener('DOMContentLoaded', () => {
  const page = pages[document.body.dataset.page];
  if (page) page().then(() => { document.body.dataset.ready = 'true'; })
                  .catch((e) => { showError(e.message); document.body.dataset.ready = 'error'; });
});
