// A session: summary, station health, lesson verdict, the replay with its
// plots (docs/web.md, "Session series"). Loaded after common.js, Chart.js and
// stations.js (the health texts).
'use strict';

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

function drawFrame(replay, index) {
  const frames = replay.frames;
  const f = frames[index];
  let shape = null;
  for (let i = index; i >= 0 && !shape; i--) if (frames[i].scope_mm) shape = frames[i];
  drawShape($('fluoro'), shape, replay.bounds);
  $('fig-t').textContent = f.t_s.toFixed(1) + ' s';
  $('tip-depth').textContent = (f.tip_arc_m * 1000).toFixed(0) + ' mm';
  $('fig-inserted').textContent = (f.inserted_m * 1000).toFixed(0) + ' mm';
  $('fig-force').textContent = f.base_force_N.toFixed(2) + ' N';
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
  markHealthFlags(healthDds.slice(1), s.station_health_flags);
  showVerdict(s.lesson_verdict);
  const series = await seriesPromise;
  const b = {x0: Infinity, x1: -Infinity, y0: Infinity, y1: -Infinity};
  for (const f of series.frames) growBounds(b, f);
  if (!(b.x1 > b.x0)) { b.x0 = -200; b.x1 = 200; b.y0 = -200; b.y1 = 200; }
  series.bounds = b;
  ves.replay = series;
  $('replay-status').textContent = series.summary;
  $('replay-status').classList.remove('busy');
  $('replay').hidden = false;
  const frames = series.frames;
  const seek = (t) => showReplayAt(timeIndex(frames, t), t);
  ves.charts.force = timeChart($('plot-force'), 'Hand force (N)', frames,
                               [['base force N', 'base_force_N', 1, '#a33']], seek);
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

pages.session = sessionPage;
