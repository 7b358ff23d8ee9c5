// Live proctoring (docs/web.md, "Live"). Loaded after common.js.
'use strict';

// Live: the institution's running sessions; with ?session=UUID, that one's
// frames over a WebSocket (the server sends only the newest to a slow page).
async function livePage() {
  await signedIn();
  const uuid = param('session');
  const list = async () => {
    const live = (await api('live')).live;
    const body = tableBody('live-list');
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
    growBounds(b, f);
    if (b.x1 > b.x0 && b.y1 > b.y0) drawShape($('live-fluoro'), f, b);
    ves.live.frames += 1;
    ves.live.tips.push(f.tip_arc_m);
    $('live-t').textContent = Number(f.t_s).toFixed(1) + ' s';
    $('live-tip-depth').textContent = (f.tip_arc_m * 1000).toFixed(0) + ' mm';
    $('live-inserted').textContent = (f.inserted_m * 1000).toFixed(0) + ' mm';
    $('live-force').textContent = Number(f.base_force_N).toFixed(2) + ' N';
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

pages.live = livePage;
