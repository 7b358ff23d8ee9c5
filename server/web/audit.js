// The audit log (docs/web.md, "Audit log"). Loaded after common.js.
'use strict';

// The audit log, newest first, a page at a time, filtered as the form (and
// the address: audit.html?actor=&action=&from=&to=) says.
async function auditPage() {
  await signedIn();
  let filter = '';
  for (const [name, input] of [['actor', 'filter-actor'], ['action', 'filter-action']]) {
    const v = param(name);
    $(input).value = v;
    if (v) filter += '&' + name + '=' + encodeURIComponent(v);
  }
  for (const [name, input, key, extra] of [['from', 'filter-from', 'from_unix_ms', 0],
                                           ['to', 'filter-to', 'to_unix_ms', DAY_MS]]) {
    const v = param(name);
    if (!v) continue;
    const ms = utcDayMs(v);
    if (Number.isNaN(ms)) throw new Error(name + ' = \'' + v + '\': not a date (YYYY-MM-DD)');
    $(input).value = v;
    filter += '&' + key + '=' + (ms + extra);
  }
  const body = tableBody('audit');
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

pages.audit = auditPage;
