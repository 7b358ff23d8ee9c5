// What every page of the VES supervisors' site shares (docs/web.md): the
// head's viewport and style, the header with its navigation, the error line,
// the API call, the helpers that put data in the page, and the page table.
// Loaded first, without defer, by every page; the page's own script (defer)
// adds its entry to `pages`, which runs once the document is parsed. Data is
// only ever put in the page as text (textContent), never parsed as HTML.
'use strict';

const ves = {charts: {}};
window.ves = ves;

// Each page's loader by its <body data-page>, added by the page scripts.
const pages = {};

const DAY_MS = 24 * 3600 * 1000;

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

// The body of the table with this id.
function tableBody(id) { return $(id).querySelector('tbody'); }

function when(ms) {
  const n = Number(ms);
  return n > 0 ? new Date(n).toISOString().replace('T', ' ').slice(0, 19) + ' UTC' : '—';
}

function fixed(v, digits) { return v === null || v === undefined ? '—' : Number(v).toFixed(digits); }

// OUTCOME_CECUM_REACHED -> "cecum reached" (the enum name as words).
function outcomeText(outcome) {
  return String(outcome || '').replace(/^OUTCOME_/, '').toLowerCase().replace(/_/g, ' ');
}

// A UTC day (YYYY-MM-DD, as a date input gives it) as Unix ms at its start;
// NaN when it is not one.
function utcDayMs(day) {
  const m = /^(\d{4})-(\d{2})-(\d{2})$/.exec(day);
  return m ? Date.UTC(Number(m[1]), Number(m[2]) - 1, Number(m[3])) : NaN;
}

// The query of the UTC days `from` to `to` (both included, empty: no bound):
// "&from_unix_ms=...&to_unix_ms=..." ("" with neither).
function dayRangeQuery(from, to) {
  const fromMs = utcDayMs(from), toMs = utcDayMs(to);
  let q = '';
  if (!Number.isNaN(fromMs)) q += '&from_unix_ms=' + fromMs;
  if (!Number.isNaN(toMs)) q += '&to_unix_ms=' + (toMs + DAY_MS);
  return q;
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

// Every item of a paged listing (`path` answers {key: [...], next_page_token}).
async function forEachPage(path, key, each) {
  let token = '';
  do {
    const page = await api(path + (path.includes('?') ? '&' : '?') + 'page_size=500' +
                           (token ? '&page_token=' + encodeURIComponent(token) : ''));
    for (const item of page[key]) each(item);
    token = page.next_page_token;
  } while (token);
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

// The box `b` grown to hold a frame's colon and scope shapes.
function growBounds(b, frame) {
  for (const p of (frame.colon_mm || []).concat(frame.scope_mm || [])) {
    b.x0 = Math.min(b.x0, p[0]); b.x1 = Math.max(b.x1, p[0]);
    b.y0 = Math.min(b.y0, p[1]); b.y1 = Math.max(b.y1, p[1]);
  }
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

// ---- the page's frame ---------------------------------------------------

// The head's viewport and style sheet, while the head is being parsed.
(function head() {
  document.head.appendChild(el('meta', null, {name: 'viewport',
                                              content: 'width=device-width, initial-scale=1'}));
  document.head.appendChild(el('link', null, {rel: 'stylesheet', href: '/style.css'}));
})();

// The header (brand, navigation shown once signed in) before <main>, and the
// error line at the end of <main>.
function frame() {
  const header = el('header');
  header.appendChild(el('a', 'VES supervisors', {class: 'brand', href: '/trainees.html'}));
  const nav = header.appendChild(el('nav', null, {id: 'nav', hidden: ''}));
  for (const [text, href] of [['Trainees', '/trainees.html'], ['Live', '/live.html'],
                              ['Stations', '/stations.html']]) {
    nav.appendChild(link(text, href));
    nav.appendChild(document.createTextNode(' '));
  }
  nav.appendChild(el('a', 'Audit', {href: '/audit.html', id: 'nav-audit', hidden: ''}));
  nav.appendChild(document.createTextNode(' '));
  nav.appendChild(el('span', null, {id: 'who'}));
  nav.appendChild(document.createTextNode(' '));
  nav.appendChild(el('button', 'Sign out', {id: 'sign-out', type: 'button'}));
  const main = document.querySelector('main');
  document.body.insertBefore(header, main);
  main.appendChild(el('p', null, {id: 'error', class: 'error', role: 'alert', hidden: ''}));
}

document.addEventListener('DOMContentLoaded', () => {
  frame();
  const page = pages[document.body.dataset.page];
  if (page) page().then(() => { document.body.dataset.ready = 'true'; })
                  .catch((e) => { showError(e.message); document.body.dataset.ready = 'error'; });
});
