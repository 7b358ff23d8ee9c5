// A trainee's learning curves and sessions (docs/web.md, "Learning curve",
// "Export"). Loaded after common.js and Chart.js; the expert band's text is
// cohort.js's.
'use strict';

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
    const range = dayRangeQuery($('export-from').value, $('export-to').value);
    $('export-csv').href = '/api/v1/trainees/' + encodeURIComponent(id) + '/sessions.csv' +
                           range.replace('&', '?');
  };
  for (const input of ['export-from', 'export-to']) $(input).addEventListener('change', exportLink);
  exportLink();
  const sessions = await api('trainees/' + encodeURIComponent(id) + '/sessions?page_size=500');
  const signOffs = await api('trainees/' + encodeURIComponent(id) + '/sign-offs');
  const signedOff = new Map(signOffs.sign_offs.map((o) => [o.session_uuid, o]));
  const body = tableBody('sessions');
  for (const s of sessions.sessions.slice().reverse()) {
    const so = signedOff.get(s.uuid);
    body.appendChild(row([link(when(s.start_unix_ms), '/session.html?uuid=' + encodeURIComponent(s.uuid)),
                          s.case_id, outcomeText(s.outcome), Number(s.score).toFixed(1),
                          s.completed ? Number(s.time_to_cecum_s).toFixed(1) + ' s' : '—',
                          so ? (so.signed_by_label || so.signed_by) + ', ' + when(so.signed_unix_ms) : '—']));
  }
}

pages.trainee = traineePage;
