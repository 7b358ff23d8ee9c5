// The stations and their health (docs/web.md, "Stations"); the health texts
// also serve the session page. Loaded after common.js.
'use strict';

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
          (h.hard_faults + h.transient_faults) + ' (' + h.hard_faults +
              ' re-armed, ' + h.transient_faults + ' paused)',
          canTotal + ' (bus ' + h.can_bus_errors + ', lost ' + h.can_lost_frames +
              ', unsent ' + h.can_send_failures + ', malformed ' + h.can_malformed_frames + ')'];
}
// The server's health flags: which of healthTexts' figures each marks, and why.
const healthFlagWhy = {loop_p99: [1, 'loop p99 over its budget'], overruns: [2, 'the loop overran'],
                       safe_state: [3, 'the device went to its safe state'],
                       can_errors: [4, 'CAN errors']};

// Marks the elements showing healthTexts' figures (in its order) that the
// server's `flags` name: class "flagged" and a title saying why.
function markHealthFlags(figures, flags) {
  for (const [flag, [index, title]] of Object.entries(healthFlagWhy)) {
    if (!flags.includes(flag)) continue;
    figures[index].classList.add('flagged');
    figures[index].setAttribute('title', title);
  }
}

// Stations: one row each, health figures as text; a flagged cell gets the
// class "flagged" and a title saying why (the server decides the flags).
async function stationsPage() {
  const me = await signedIn();
  $('institution').textContent = me.institution;
  const body = tableBody('stations');
  await forEachPage('stations', 'stations', (s) => {
    const cells = [s.station_id, when(s.last_seen_unix_ms), s.software_version || '—']
        .concat(healthTexts(s.health));
    const tr = row(cells);
    tr.dataset.station = s.station_id;
    markHealthFlags([...tr.children].slice(3), s.flags);
    if (s.flags.length > 0) tr.classList.add('unhealthy');
    body.appendChild(tr);
  });
  $('no-stations').hidden = body.children.length > 0;
}

pages.stations = stationsPage;
