// The trainee list with its groups, and a group's lesson progress (docs/web.md).
// Loaded after common.js; the list's curricula cells are cohort.js's.
'use strict';

async function traineesPage() {
  const me = await signedIn();
  $('institution').textContent = me.institution;
  const body = tableBody('trainees');
  const groups = new Set();
  await forEachPage('trainees', 'trainees', (t) => {
    body.appendChild(row([
      link(t.trainee_id, '/trainee.html?id=' + encodeURIComponent(t.trainee_id)),
      t.display_name,
      t.group ? link(t.group, '/group.html?group=' + encodeURIComponent(t.group)) : '—',
      t.sessions, when(t.last_activity_unix_ms), curriculaCell(t.curricula)]));
    if (t.group) groups.add(t.group);
  });
  for (const g of [...groups].sort()) {
    const li = el('li');
    li.appendChild(link(g, '/group.html?group=' + encodeURIComponent(g)));
    li.appendChild(document.createTextNode(' · '));
    li.appendChild(link('lesson progress', '/progress.html?group=' + encodeURIComponent(g)));
    $('groups').appendChild(li);
  }
}

async function progressPage() {
  await signedIn();
  const group = param('group');
  $('group-name').textContent = group;
  const progress = await api('groups/' + encodeURIComponent(group) + '/progress');
  const lessons = [];
  for (const t of progress.trainees) for (const l of t.lessons) if (!lessons.includes(l.lesson_id)) lessons.push(l.lesson_id);
  $('progress').querySelector('thead').appendChild(row(['Trainee', 'Next lesson'].concat(lessons)));
  const body = tableBody('progress');
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

pages.trainees = traineesPage;
pages.progress = progressPage;
