// Proficiency, the group (cohort) page and the printable trainee report
// (docs/web.md, "Proficiency", "Cohorts", "Export"). Loaded after common.js,
// whose helpers and page table it uses; data goes in as text only.
'use strict';

// "Title: 2/3" per assigned curriculum, "proficient" when all are passed.
function curriculaCell(curricula) {
  const span = el('span', null, {class: 'curricula'});
  if (!curricula || !curricula.length) {
    span.textContent = '—';
    return span;
  }
  curricula.forEach((c, i) => {
    if (i > 0) span.appendChild(el('br'));
    span.appendChild(el('span', (c.title || c.curriculum_id) + ': ' + c.passed + '/' + c.lessons,
                        {'data-curriculum': c.curriculum_id}));
    if (c.proficient) {
      span.appendChild(document.createTextNode(' '));
      span.appendChild(el('span', 'proficient', {class: 'badge proficient'}));
    }
  });
  return span;
}

function expertBandText(band) {
  const range = (key, unit) => band[key]
      ? band[key][0].toFixed(1) + '–' + band[key][1].toFixed(1) + unit : 'none';
  return 'Expert band: the scripted expert\'s ' + band.runs + ' run(s) of this case: score ' +
         range('score', '') + ', time to cecum ' + range('time_to_cecum_s', ' s') + ', pain ' +
         range('pain_s', ' s') + ', loop ' + range('loop_s', ' s') + '.';
}

// The cohort table's columns: header, value of a trainee row (for sorting),
// text shown.
function cohortColumns(runs) {
  const f = (t) => t[runs];
  const lessonsPassed = (t) => t.curricula.reduce((n, c) => n + c.passed, 0);
  const lessonsTotal = (t) => t.curricula.reduce((n, c) => n + c.lessons, 0);
  return [
    ['Trainee', (t) => t.trainee_id, (t) => link(t.trainee_id, '/trainee.html?id=' + encodeURIComponent(t.trainee_id))],
    ['Name', (t) => t.display_name, (t) => t.display_name],
    ['Attempts', (t) => f(t).attempts, (t) => f(t).attempts],
    ['Best score', (t) => f(t).best_score, (t) => fixed(f(t).best_score, 1)],
    ['Last score', (t) => f(t).last_score, (t) => fixed(f(t).last_score, 1)],
    ['Cecum reached', (t) => f(t).cecum_reached, (t) => f(t).cecum_reached + '/' + f(t).attempts],
    ['Time to cecum (median s)', (t) => f(t).time_to_cecum_s, (t) => fixed(f(t).time_to_cecum_s, 1)],
    ['Pain (median s)', (t) => f(t).pain_s, (t) => fixed(f(t).pain_s, 1)],
    ['Loop (median s)', (t) => f(t).loop_s, (t) => fixed(f(t).loop_s, 1)],
    ['X-ray (median s)', (t) => f(t).xray_s, (t) => fixed(f(t).xray_s, 1)],
    ['Lessons passed', (t) => lessonsPassed(t), (t) => lessonsTotal(t) ? lessonsPassed(t) + '/' + lessonsTotal(t) : '—'],
    ['Proficient', (t) => t.curricula.filter((c) => c.proficient).length,
     (t) => t.curricula.filter((c) => c.proficient).map((c) => c.title || c.curriculum_id).join(', ') || '—'],
    ['Report', null, (t) => link('report', '/report.html?id=' + encodeURIComponent(t.trainee_id))],
  ];
}

// Nulls (no figure) sort last whichever the direction.
function compareValues(a, b, direction) {
  const na = a === null || a === undefined, nb = b === null || b === undefined;
  if (na || nb) return na === nb ? 0 : na ? 1 : -1;
  const c = typeof a === 'string' ? a.localeCompare(b) : a - b;
  return direction * c;
}

async function groupPage() {
  await signedIn();
  const group = param('group');
  $('group-name').textContent = group;
  $('progress-link').href = '/progress.html?group=' + encodeURIComponent(group);
  const state = {trainees: [], sortColumn: 0, direction: 1};
  ves.cohort = state;
  const render = () => {
    const runs = $('runs').value;
    const columns = cohortColumns(runs);
    const head = $('cohort').querySelector('thead');
    head.textContent = '';
    const tr = head.appendChild(el('tr'));
    columns.forEach(([title, value], i) => {
      const th = tr.appendChild(el('th'));
      if (!value) {
        th.textContent = title;
        return;
      }
      const button = th.appendChild(el('button', title, {type: 'button', class: 'sort'}));
      th.setAttribute('aria-sort', i !== state.sortColumn ? 'none'
                                   : state.direction > 0 ? 'ascending' : 'descending');
      button.addEventListener('click', () => {
        state.direction = state.sortColumn === i ? -state.direction : 1;
        state.sortColumn = i;
        render();
      });
    });
    const sorter = columns[state.sortColumn][1];
    const sorted = state.trainees.slice().sort(
        (a, b) => compareValues(sorter(a), sorter(b), state.direction) ||
                  a.trainee_id.localeCompare(b.trainee_id));
    const body = tableBody('cohort');
    body.textContent = '';
    for (const t of sorted) body.appendChild(row(columns.map(([, , show]) => show(t))));
    $('runs-note').textContent = runs === 'lesson'
        ? 'Lesson attempts only (sessions run for a lesson); practice runs are apart.'
        : 'Practice runs only (free runs, no lesson); lesson attempts are apart.';
  };
  const load = async () => {
    const range = dayRangeQuery($('cohort-from').value, $('cohort-to').value);
    $('cohort-csv').href = '/api/v1/groups/' + encodeURIComponent(group) + '/sessions.csv' +
                           range.replace('&', '?');
    const reply = await api('groups/' + encodeURIComponent(group) + '/cohort' + range.replace('&', '?'));
    state.trainees = reply.trainees;
    render();
  };
  for (const input of ['cohort-from', 'cohort-to']) {
    $(input).addEventListener('change', () => {
      document.body.dataset.ready = 'loading';
      load().then(() => { document.body.dataset.ready = 'true'; })
            .catch((e) => { showError(e.message); document.body.dataset.ready = 'error'; });
    });
  }
  $('runs').addEventListener('change', render);
  await load();
}

function summaryRow(label, f) {
  return row([label, f.attempts, fixed(f.best_score, 1), fixed(f.last_score, 1),
              f.cecum_reached + '/' + f.attempts, fixed(f.time_to_cecum_s, 1),
              fixed(f.pain_s, 1), fixed(f.loop_s, 1), fixed(f.xray_s, 1)]);
}

async function reportPage() {
  await signedIn();
  const id = param('id');
  const range = dayRangeQuery(param('from'), param('to'));
  const r = await api('trainees/' + encodeURIComponent(id) + '/report' + range.replace('&', '?'));
  // The title names the trainee (a saved PDF's title), once the data is in.
  document.title = 'VES · Report of ' + r.trainee_id;
  $('report-trainee').textContent = r.trainee_id;
  $('report-name').textContent = r.display_name;
  $('report-institution').textContent = r.institution;
  $('report-group').textContent = r.group || '—';
  $('report-period').textContent = (r.from_unix_ms ? when(r.from_unix_ms).slice(0, 10) : 'first session') +
      ' to ' + (r.to_unix_ms ? when(r.to_unix_ms - DAY_MS).slice(0, 10) : 'last session');
  $('report-generated').textContent = when(r.generated_unix_ms);
  const summary = tableBody('report-summary');
  summary.appendChild(summaryRow('Lesson attempts', r.lesson));
  summary.appendChild(summaryRow('Practice runs', r.practice));
  const curricula = $('report-curricula');
  if (!r.curricula.length) curricula.appendChild(el('p', 'No curriculum is assigned.'));
  for (const c of r.curricula) {
    const section = curricula.appendChild(el('section', null, {class: 'report-curriculum'}));
    section.appendChild(el('h3', (c.title || c.curriculum_id) + ': ' + c.passed + ' of ' + c.lessons +
                                 ' lessons passed' + (c.proficient ? ' — proficient' : '')));
    const table = section.appendChild(el('table'));
    table.appendChild(el('thead')).appendChild(row(['Lesson', 'Attempts', 'Passes', 'Required', 'Best score', 'Passed']));
    const body = table.appendChild(el('tbody'));
    for (const l of c.lesson_progress) {
      body.appendChild(row([l.title || l.lesson_id, l.attempts, l.passes, l.required_passes,
                            l.attempts ? Number(l.best_score).toFixed(1) : '—', l.completed ? 'yes' : 'no']));
    }
  }
  const sessions = tableBody('report-sessions');
  for (const s of r.sessions) {
    sessions.appendChild(row([when(s.start_unix_ms), s.case_id, s.lesson_id || 'practice',
                              s.verdict || '—', outcomeText(s.outcome), fixed(s.score, 1),
                              fixed(s.time_to_cecum_s, 1), fixed(s.pain_s, 1), fixed(s.loop_s, 1),
                              fixed(s.xray_s, 1)]));
  }
  $('report-none').hidden = r.sessions.length > 0;
  $('print').addEventListener('click', () => window.print());
}

pages.group = groupPage;
pages.report = reportPage;
