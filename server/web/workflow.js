// The supervisors' workflow (docs/web.md, "Workflow"): adding trainees,
// groups and assignments on the trainees and group pages, notes and the
// sign-off on the session page. Loaded after common.js (and cohort.js), whose
// helpers and page table it uses; it runs after each page's own loading.
// Data goes in as text only. The forms show to supervisors and admins; the
// server decides (403 for anyone else), and every refusal is shown in words.
'use strict';

function canWrite(me) { return me && (me.role === 'supervisor' || me.role === 'admin'); }

// A form's outcome under it: `done` (role=status) or the error (role=alert).
function formOutcome(section, message, isError) {
  let done = section.querySelector('.workflow-done');
  let error = section.querySelector('.workflow-error');
  if (!done) done = section.appendChild(el('p', null, {class: 'workflow-done', role: 'status'}));
  if (!error) error = section.appendChild(el('p', null, {class: 'error workflow-error', role: 'alert'}));
  done.textContent = isError ? '' : message;
  error.textContent = isError ? message : '';
  error.hidden = !isError;
}

// Submits `form` with `send` (returns the success message); the page is then
// read again from the server, the message shown after the reload.
function reloadingForm(form, section, send) {
  form.addEventListener('submit', async (event) => {
    event.preventDefault();
    const button = form.querySelector('button[type=submit]');
    button.disabled = true;
    try {
      sessionStorage.setItem('ves_workflow_done', await send());
      location.reload();
    } catch (e) {
      formOutcome(section, e.message, true);
      button.disabled = false;
    }
  });
}

function showDoneAfterReload(section) {
  const message = sessionStorage.getItem('ves_workflow_done');
  if (!message) return;
  sessionStorage.removeItem('ves_workflow_done');
  formOutcome(section, message, false);
}

async function curriculumOptions(select) {
  const reply = await api('curricula');
  select.replaceChildren();
  for (const c of reply.curricula) {
    select.appendChild(el('option', (c.title || c.curriculum_id) + ' (' + c.lessons + ' lessons)',
                          {value: c.curriculum_id}));
  }
  if (!reply.curricula.length) select.appendChild(el('option', 'no curriculum stored', {value: ''}));
}

function postJson(path, body) { return api(path, {method: 'POST', body: JSON.stringify(body)}); }

async function traineesWorkflow() {
  if (!canWrite(ves.me)) return;
  const section = $('workflow');
  section.hidden = false;
  showDoneAfterReload(section);
  // The trainees and groups the table shows, offered by the forms.
  const ids = [...$('trainees').querySelectorAll('tbody tr td:first-child')].map((td) => td.textContent);
  const groups = [...$('groups').querySelectorAll('li > a:first-child')].map((a) => a.textContent);
  for (const id of ids) $('group-trainee').appendChild(el('option', id, {value: id}));
  for (const g of groups) $('group-names').appendChild(el('option', null, {value: g}));
  const assignees = () => {
    const list = $('assign-kind').value === 'group' ? groups : ids;
    $('assignees').replaceChildren(...list.map((v) => el('option', null, {value: v})));
  };
  $('assign-kind').addEventListener('change', assignees);
  assignees();
  await curriculumOptions($('assign-curriculum'));

  reloadingForm($('add-trainee'), section, async () => {
    const id = $('new-trainee-id').value.trim();
    await postJson('trainees', {trainee_id: id, display_name: $('new-trainee-name').value.trim()});
    return 'Added trainee ' + id + '.';
  });
  reloadingForm($('set-group'), section, async () => {
    const id = $('group-trainee').value, group = $('group-name-input').value.trim();
    await postJson('trainees/' + encodeURIComponent(id) + '/group', {group: group});
    return group ? 'Put ' + id + ' in group ' + group + '.' : 'Took ' + id + ' out of any group.';
  });
  reloadingForm($('assign'), section, async () => {
    const kind = $('assign-kind').value, to = $('assign-to').value.trim();
    const curriculum = $('assign-curriculum').value;
    const reply = await postJson('assignments', {curriculum_id: curriculum, [kind]: to});
    return 'Assigned ' + curriculum + ' to ' + (kind === 'group' ? 'group ' : '') + to + ' (' +
           reply.trainee_ids.length + ' trainee(s)).';
  });
}

async function groupWorkflow() {
  if (!canWrite(ves.me)) return;
  const group = param('group');
  const section = $('workflow');
  section.hidden = false;
  showDoneAfterReload(section);
  await curriculumOptions($('group-assign-curriculum'));
  reloadingForm($('group-add'), section, async () => {
    const id = $('group-add-trainee').value.trim();
    await postJson('trainees/' + encodeURIComponent(id) + '/group', {group: group});
    return 'Put ' + id + ' in group ' + group + '.';
  });
  reloadingForm($('group-assign'), section, async () => {
    const curriculum = $('group-assign-curriculum').value;
    const reply = await postJson('assignments', {curriculum_id: curriculum, group: group});
    return 'Assigned ' + curriculum + ' to group ' + group + ' (' + reply.trainee_ids.length +
           ' trainee(s)).';
  });
}

// The session's notes, oldest first, and its sign-off.
function showNotes(reply) {
  const list = $('notes');
  list.replaceChildren();
  for (const n of reply.notes) {
    const li = list.appendChild(el('li', null, {'data-note': n.note_id}));
    li.appendChild(el('div', (n.author_label || n.author) + ' · ' + when(n.written_unix_ms),
                      {class: 'note-by'}));
    li.appendChild(el('p', n.text, {class: 'note-text'}));
  }
  if (!reply.notes.length) list.appendChild(el('li', 'No notes yet.', {class: 'hint'}));
  const status = $('sign-off-status');
  const so = reply.sign_off;
  status.textContent = so ? 'Signed off by ' + (so.signed_by_label || so.signed_by) + ' on ' +
                            when(so.signed_unix_ms) + '.'
                          : 'Not signed off.';
  status.classList.toggle('signed', !!so);
  $('sign-off').hidden = !!so || !reply.can_write;
  $('note-form').hidden = !reply.can_write;
}

async function sessionWorkflow() {
  const uuid = param('uuid');
  const path = 'sessions/' + encodeURIComponent(uuid);
  const reload = async () => showNotes(await api(path + '/notes'));
  await reload();
  $('note-form').addEventListener('submit', async (event) => {
    event.preventDefault();
    try {
      await postJson(path + '/notes', {text: $('note-text').value});
      $('note-text').value = '';
      await reload();
      formOutcome($('notes-section'), 'Note added.', false);
    } catch (e) {
      formOutcome($('notes-section'), e.message, true);
    }
  });
  $('sign-off').addEventListener('click', async () => {
    if (!window.confirm('Sign off this session? A sign-off cannot be undone.')) return;
    try {
      await postJson(path + '/sign-off', {});
      await reload();  // the status line then says who signed off and when
    } catch (e) {
      formOutcome($('sign-off-section'), e.message, true);
    }
  });
}

// Each page's own loading first, then its workflow part.
for (const [name, after] of [['trainees', traineesWorkflow], ['group', groupWorkflow],
                             ['session', sessionWorkflow]]) {
  const own = pages[name];
  pages[name] = async () => {
    if (name === 'session') {
      // The notes need no wait for the plots (seconds on a first view); the
      // notes' reply says whether this caller may write.
      await Promise.all([own(), after()]);
      return;
    }
    await own();
    await after();
  };
}
